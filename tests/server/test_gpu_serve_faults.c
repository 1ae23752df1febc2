/* Faults of the daemon with a data directory (issue: deployable and hardened): kill -9 during
 * an upload and during state writes, then a restart finds a consistent state and no temporary
 * files; a corrupt state file gives one clear log line, is kept aside and the daemon starts
 * with defaults; SIGTERM with viewers and an upload in flight exits 0. */
#include <dirent.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "serve_util.h"
#include "test_util.h"

static char data_dir[512], log_path[600];

static const char *const small[] = {"--no-animate", "--width", "32",     "--height", "24",
                                    "--probes",     "2,2,2",   "--rays", "16",       NULL};

static bool start(pc_daemon *d)
{
    const char *args[32];
    int n = 0;
    for (int i = 0; small[i]; i++)
        args[n++] = small[i];
    args[n++] = "--data-dir";
    args[n++] = data_dir;
    args[n] = NULL;
    d->log_path = log_path;
    return pc_daemon_start(d, args);
}

static void kill9(pc_daemon *d)
{
    kill(d->pid, SIGKILL);
    waitpid(d->pid, NULL, 0);
    d->pid = 0;
}

/* Files in the data directory whose names end in suffix (or contain it when contains). */
static unsigned count_files(const char *part, bool suffix)
{
    DIR *dir = opendir(data_dir);
    unsigned n = 0;
    struct dirent *e;
    while (dir && (e = readdir(dir)) != NULL) {
        size_t len = strlen(e->d_name), k = strlen(part);
        if (suffix ? len >= k && strcmp(e->d_name + len - k, part) == 0
                   : strstr(e->d_name, part) != NULL)
            n++;
    }
    if (dir) closedir(dir);
    return n;
}

static double setting(pc_daemon *d, const char *name)
{
    cJSON *s = pc_api_get_json(d, "/v1/settings");
    double v = pc_json_number(s, name);
    cJSON_Delete(s);
    return v;
}

/* An upload whose body stops half way: the connection stays open. */
static int partial_upload(pc_daemon *d)
{
    int fd = pc_dial("127.0.0.1", d->http_port, 5000);
    char head[256];
    int n = snprintf(head, sizeof head,
                     "PUT /v1/scene HTTP/1.1\r\nHost: 127.0.0.1:%u\r\nContent-Type: "
                     "model/gltf-binary\r\nContent-Length: 4000000\r\n\r\n",
                     d->http_port);
    static char body[200000];
    memset(body, ' ', sizeof body);
    if (fd >= 0 && (pc_send_all(fd, head, (size_t)n) != 0 || pc_send_all(fd, body, sizeof body)))
        CHECK(!"the partial upload was sent");
    return fd;
}

static bool log_has(const char *a, const char *b)
{
    FILE *f = fopen(log_path, "r");
    char line[2048];
    bool found = false;
    while (f && !found && fgets(line, sizeof line, f))
        found = strstr(line, a) && strstr(line, b);
    if (f) fclose(f);
    return found;
}

int main(void)
{
    snprintf(data_dir, sizeof data_dir, "%s", test_tmp_path("faults-data"));
    snprintf(log_path, sizeof log_path, "%s", test_tmp_path("faults-daemon.log"));
    char cmd[1400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' '%s'", data_dir, log_path);
    CHECK(system(cmd) == 0);

    /* an accepted upload and a setting, saved */
    pc_daemon d = {0};
    if (!start(&d)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.5f, &glb_size);
    pc_http_response r;
    CHECK(pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                  "Content-Type: model/gltf-binary\r\n", glb, glb_size, &r, 120000) == 200);
    pc_http_response_free(&r);
    free(glb);
    CHECK(pc_api(&d, "PATCH", "/v1/settings", "{\"exposure\":1.5}", false, &r) == 200);
    pc_http_response_free(&r);
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    double generation = pc_json_number(scene, "generation");
    cJSON_Delete(scene);
    pc_sleep_ms(1000); /* the state is written within a quarter of a second */

    /* kill -9 in the middle of an upload: the saved scene and state are the old ones */
    int fd = partial_upload(&d);
    pc_sleep_ms(300);
    kill9(&d);
    if (fd >= 0) close(fd);
    CHECK(start(&d));
    scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *src = cJSON_GetObjectItemCaseSensitive(scene, "source");
    CHECK(cJSON_IsString(src) && strcmp(src->valuestring, "upload") == 0);
    CHECKF(pc_json_number(scene, "generation") == generation,
           "generation %g after the kill, %g before", pc_json_number(scene, "generation"),
           generation);
    CHECK(pc_json_number(scene, "triangles") == 14);
    cJSON_Delete(scene);
    CHECK(setting(&d, "exposure") == 1.5);
    CHECK(count_files(".tmp", true) == 0);

    /* kill -9 while state writes are under way (a burst of changes, killed right after one
     * returns), five times: every restart reads a state the API had given, never a torn one */
    for (int round = 0; round < 5; round++) {
        double last = NAN;
        for (int k = 0; k < 12; k++) {
            char body[64];
            last = 0.25 * (round * 12 + k + 1);
            snprintf(body, sizeof body, "{\"exposure\":%g}", last);
            CHECK(pc_api(&d, "PATCH", "/v1/settings", body, false, &r) == 200);
            pc_http_response_free(&r);
            pc_sleep_ms(round * 60); /* a different moment of the write each round */
        }
        kill9(&d);
        CHECK(start(&d));
        double e = setting(&d, "exposure");
        /* the newest change, or one a little older that was on disk when the kill came */
        CHECKF(e > 0 && e <= last && fmod(e, 0.25) == 0, "round %d: exposure %g (last sent %g)",
               round, e, last);
        CHECK(count_files(".tmp", true) == 0);
    }

    /* a corrupt state file: one clear line, the file kept aside, defaults */
    CHECK(pc_daemon_stop(&d) == 0);
    char path[700];
    snprintf(path, sizeof path, "%s/state.json", data_dir);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fputs("{\"version\": 1, \"generation\": 3, \"sta", f);
        fclose(f);
    }
    CHECK(start(&d));
    CHECKF(log_has("state.json is not a saved state", "kept as"), "the log says what happened");
    CHECK(count_files("state.json.bad-", false) == 1);
    CHECK(setting(&d, "exposure") == 0);
    scene = pc_api_get_json(&d, "/v1/scene");
    CHECK(pc_json_number(scene, "generation") == generation); /* the scene itself was fine */
    cJSON_Delete(scene);

    /* SIGTERM with two viewers and an upload in flight: a clean exit */
    pc_ws a, b;
    CHECK(pc_stream_open(&d, &a));
    CHECK(pc_stream_open(&d, &b));
    pc_frame fr = {0};
    CHECK(pc_stream_next(&a, 60000, true, &fr));
    pc_frame_free(&fr);
    fd = partial_upload(&d);
    pc_sleep_ms(200);
    CHECKF(pc_daemon_stop(&d) == 0, "exit status 0 after SIGTERM with viewers and an upload");
    if (fd >= 0) close(fd);
    pc_ws_close(&a);
    pc_ws_close(&b);
    CHECK(count_files(".tmp", true) == 0);
    return test_finish();
}
