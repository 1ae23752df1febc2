/* persist.c: atomic files in --data-dir written by a background thread. */
#include "server/scene/persist.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "server/base/log.h"
#include "renderer/env/environment.h"

#define STATE_INTERVAL_MS 250

struct srv_persist {
    char dir[1024];
    pthread_mutex_t mu;
    pthread_cond_t cv;
    pthread_t thread;
    bool stop;
    /* pending writes */
    uint8_t *scene;
    size_t scene_size;
    uint64_t scene_generation;
    cJSON *state;
    uint64_t state_generation;
    char state_source[128];
    bool env_pending; /* env bytes to write, or (env NULL) the file to remove */
    uint8_t *env;
    size_t env_size;
};

static int write_all(int fd, const void *data, size_t size)
{
    const char *p = data;
    while (size > 0) {
        ssize_t n = write(fd, p, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        p += n;
        size -= (size_t)n;
    }
    return 0;
}

int srv_write_file_atomic(const char *path, const void *data, size_t size)
{
    char tmp[1100];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return errno;
    int rc = write_all(fd, data, size);
    if (rc == 0 && fsync(fd) != 0) rc = errno;
    if (close(fd) != 0 && rc == 0) rc = errno;
    if (rc == 0 && rename(tmp, path) != 0) rc = errno;
    if (rc != 0) {
        unlink(tmp);
        return rc;
    }
    char dircopy[1100];
    snprintf(dircopy, sizeof dircopy, "%s", path);
    int dfd = open(dirname(dircopy), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd < 0) return errno;
    if (fsync(dfd) != 0) rc = errno;
    close(dfd);
    return rc;
}

static void path_of(const srv_persist *p, const char *name, char *out, size_t outlen)
{
    snprintf(out, outlen, "%s/%s", p->dir, name);
}

static void write_scene(srv_persist *p, uint64_t gen, const uint8_t *bytes, size_t size)
{
    char path[1100];
    path_of(p, "scene.bin", path, sizeof path);
    int rc = srv_write_file_atomic(path, bytes, size);
    if (rc == 0) {
        char meta[128];
        int n = snprintf(meta, sizeof meta, "{\"generation\":%llu,\"size\":%zu}\n",
                         (unsigned long long)gen, size);
        path_of(p, "scene.json", path, sizeof path);
        rc = srv_write_file_atomic(path, meta, (size_t)n);
    }
    if (rc != 0)
        srv_error("persist", "cannot save the scene in %s: %s", p->dir, strerror(rc));
    else
        srv_info("persist", "saved scene generation %llu (%zu bytes)", (unsigned long long)gen,
                 size);
}

/* The data folder's name for an environment image of format f: environment.EXT. */
static bool environment_path(const srv_persist *p, rd_env_format f, char *out, size_t outlen)
{
    const char *ext = rd_env_format_extension(f);
    if (!ext) return false;
    char name[64];
    snprintf(name, sizeof name, "environment.%s", ext);
    path_of(p, name, out, outlen);
    return true;
}

/* Removes the saved environment images of every format but keep (all when it is UNKNOWN). */
static int remove_environments(const srv_persist *p, rd_env_format keep)
{
    int rc = 0;
    char path[1100];
    for (int f = RD_ENV_FORMAT_UNKNOWN + 1; f < RD_ENV_FORMAT_COUNT; f++)
        if (f != (int)keep && environment_path(p, (rd_env_format)f, path, sizeof path) &&
            unlink(path) != 0 && errno != ENOENT)
            rc = errno;
    return rc;
}

/* Saves the image as environment.hdr or environment.exr (by its first bytes), then removes the
 * other one: a crash in between leaves both, and srv_persist_load takes the newer. */
static void write_environment(srv_persist *p, const uint8_t *bytes, size_t size)
{
    rd_env_format f = bytes ? rd_env_image_format(bytes, size) : RD_ENV_FORMAT_UNKNOWN;
    char path[1100];
    int rc = 0;
    if (bytes && !environment_path(p, f, path, sizeof path)) {
        srv_error("persist", "the environment image is of no known format; not saved");
        return;
    }
    if (bytes) rc = srv_write_file_atomic(path, bytes, size);
    if (rc == 0) rc = remove_environments(p, f);
    if (rc != 0)
        srv_error("persist", "cannot save the environment in %s: %s", p->dir, strerror(rc));
    else if (bytes)
        srv_info("persist", "saved the environment image as environment.%s (%zu bytes)",
                 rd_env_format_extension(f), size);
    else
        srv_info("persist", "removed the environment image");
}

static void write_state(srv_persist *p, uint64_t gen, const char *source, cJSON *state)
{
    cJSON *doc = cJSON_CreateObject();
    cJSON_AddNumberToObject(doc, "version", 1);
    cJSON_AddNumberToObject(doc, "generation", (double)gen);
    cJSON_AddStringToObject(doc, "source", source);
    cJSON_AddItemToObject(doc, "state", state);
    char *text = cJSON_Print(doc);
    cJSON_Delete(doc);
    if (!text) abort();
    char path[1100];
    path_of(p, "state.json", path, sizeof path);
    int rc = srv_write_file_atomic(path, text, strlen(text));
    free(text);
    if (rc != 0)
        srv_error("persist", "cannot save the state in %s: %s", p->dir, strerror(rc));
    else
        srv_debug("persist", "saved state (generation %llu)", (unsigned long long)gen);
}

static void *persist_main(void *arg)
{
    srv_persist *p = arg;
    pthread_mutex_lock(&p->mu);
    for (;;) {
        while (!p->stop && !p->scene && !p->state && !p->env_pending)
            pthread_cond_wait(&p->cv, &p->mu);
        bool env_pending = p->env_pending;
        uint8_t *env = p->env;
        size_t env_size = p->env_size;
        p->env_pending = false;
        p->env = NULL;
        uint8_t *scene = p->scene;
        size_t scene_size = p->scene_size;
        uint64_t scene_gen = p->scene_generation;
        p->scene = NULL;
        cJSON *state = p->state;
        uint64_t state_gen = p->state_generation;
        char source[128];
        memcpy(source, p->state_source, sizeof source);
        p->state = NULL;
        bool stop = p->stop;
        pthread_mutex_unlock(&p->mu);
        if (scene) {
            write_scene(p, scene_gen, scene, scene_size);
            free(scene);
        }
        if (env_pending) write_environment(p, env, env_size);
        free(env);
        if (state) write_state(p, state_gen, source, state);
        if (stop) {
            pthread_mutex_lock(&p->mu);
            if (!p->scene && !p->state && !p->env_pending) break;
            continue;
        }
        /* coalesce state documents: the newest of the next interval wins */
        struct timespec ts = {0, STATE_INTERVAL_MS * 1000000L};
        nanosleep(&ts, NULL);
        pthread_mutex_lock(&p->mu);
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

/* A run killed while it wrote a file leaves NAME.tmp beside the intact NAME (rename is the
 * commit): those are removed at start. */
static void remove_stray_temporaries(const srv_persist *p)
{
    DIR *d = opendir(p->dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".tmp") != 0) continue;
        char path[1400];
        snprintf(path, sizeof path, "%s/%s", p->dir, e->d_name);
        if (unlink(path) == 0)
            srv_info("persist", "removed %s, left by a run that stopped while writing it", path);
    }
    closedir(d);
}

/* A file that does not read as what it should be is renamed NAME.bad-TIME (kept for a look,
 * never read again) so that the next start does not trip over it. */
static void keep_aside(const srv_persist *p, const char *name, const char *why)
{
    char from[1100], to[1200];
    path_of(p, name, from, sizeof from);
    snprintf(to, sizeof to, "%s.bad-%lld", from, (long long)time(NULL));
    if (rename(from, to) == 0)
        srv_warn("persist", "%s %s: kept as %s; starting without it", from, why, to);
    else
        srv_warn("persist", "%s %s; ignored (and it cannot be moved aside: %s)", from, why,
                 strerror(errno));
}

srv_persist *srv_persist_open(const char *dir, char *err, size_t errlen)
{
    if (strlen(dir) >= 1000) {
        snprintf(err, errlen, "the data folder path is too long");
        return NULL;
    }
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        snprintf(err, errlen, "cannot create the data folder %s: %s", dir, strerror(errno));
        return NULL;
    }
    struct stat sb;
    if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode) || access(dir, W_OK) != 0) {
        snprintf(err, errlen, "%s is not a writable folder", dir);
        return NULL;
    }
    srv_persist *p = calloc(1, sizeof *p);
    if (!p) abort();
    snprintf(p->dir, sizeof p->dir, "%s", dir);
    remove_stray_temporaries(p);
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->cv, NULL);
    if (pthread_create(&p->thread, NULL, persist_main, p) != 0) {
        snprintf(err, errlen, "cannot start the persistence thread");
        pthread_cond_destroy(&p->cv);
        pthread_mutex_destroy(&p->mu);
        free(p);
        return NULL;
    }
    return p;
}

void srv_persist_close(srv_persist *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->stop = true;
    pthread_cond_signal(&p->cv);
    pthread_mutex_unlock(&p->mu);
    pthread_join(p->thread, NULL);
    free(p->scene);
    free(p->env);
    cJSON_Delete(p->state);
    pthread_cond_destroy(&p->cv);
    pthread_mutex_destroy(&p->mu);
    free(p);
}

void srv_persist_post_scene(srv_persist *p, uint64_t generation, uint8_t *bytes, size_t size)
{
    if (!p) {
        free(bytes);
        return;
    }
    pthread_mutex_lock(&p->mu);
    if (p->scene && p->scene_generation > generation) {
        free(bytes); /* an older upload arriving late */
    } else {
        free(p->scene);
        p->scene = bytes;
        p->scene_size = size;
        p->scene_generation = generation;
    }
    pthread_cond_signal(&p->cv);
    pthread_mutex_unlock(&p->mu);
}

void srv_persist_post_environment(srv_persist *p, uint8_t *bytes, size_t size)
{
    if (!p) {
        free(bytes);
        return;
    }
    pthread_mutex_lock(&p->mu);
    free(p->env); /* the newest wins */
    p->env = bytes;
    p->env_size = size;
    p->env_pending = true;
    pthread_cond_signal(&p->cv);
    pthread_mutex_unlock(&p->mu);
}

void srv_persist_post_state(srv_persist *p, uint64_t generation, const char *source, cJSON *doc)
{
    if (!p) {
        cJSON_Delete(doc);
        return;
    }
    pthread_mutex_lock(&p->mu);
    cJSON_Delete(p->state);
    p->state = doc;
    p->state_generation = generation;
    snprintf(p->state_source, sizeof p->state_source, "%s", source ? source : "");
    pthread_cond_signal(&p->cv);
    pthread_mutex_unlock(&p->mu);
}

/* Reads a whole file (at most max bytes); NULL when missing or unreadable. */
static uint8_t *read_file(const char *path, size_t max, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    uint8_t *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len == cap) {
            cap = cap ? cap * 2 : 65536;
            uint8_t *nb = realloc(buf, cap + 1);
            if (!nb) abort();
            buf = nb;
        }
        size_t n = fread(buf + len, 1, cap - len, f);
        len += n;
        if (n == 0 || len > max) break;
    }
    bool bad = ferror(f) || len > max;
    fclose(f);
    if (bad) {
        free(buf);
        return NULL;
    }
    buf[len] = 0;
    *size = len;
    return buf;
}

/* The saved environment image: the newest of environment.hdr and environment.exr (two exist
 * only after a crash between writing one and removing the other; the older is removed). */
static void load_environment(const srv_persist *p, srv_saved *out)
{
    char path[1100];
    rd_env_format newest = RD_ENV_FORMAT_UNKNOWN;
    struct timespec newest_time = {0, 0};
    int found = 0;
    for (int f = RD_ENV_FORMAT_UNKNOWN + 1; f < RD_ENV_FORMAT_COUNT; f++) {
        struct stat sb;
        if (!environment_path(p, (rd_env_format)f, path, sizeof path) || stat(path, &sb) != 0)
            continue;
        found++;
        if (newest == RD_ENV_FORMAT_UNKNOWN || sb.st_mtim.tv_sec > newest_time.tv_sec ||
            (sb.st_mtim.tv_sec == newest_time.tv_sec && sb.st_mtim.tv_nsec > newest_time.tv_nsec)) {
            newest = (rd_env_format)f;
            newest_time = sb.st_mtim;
        }
    }
    if (newest == RD_ENV_FORMAT_UNKNOWN) return;
    if (found > 1) {
        srv_info("persist",
                 "%d saved environment images: environment.%s is the newest, the others "
                 "are removed",
                 found, rd_env_format_extension(newest));
        remove_environments(p, newest);
    }
    environment_path(p, newest, path, sizeof path);
    out->environment = read_file(path, (size_t)1 << 31, &out->environment_size);
}

void srv_persist_load(srv_persist *p, srv_saved *out)
{
    memset(out, 0, sizeof *out);
    if (!p) return;
    char path[1100];
    size_t size;
    path_of(p, "scene.json", path, sizeof path);
    uint8_t *meta = read_file(path, 4096, &size);
    if (meta) {
        cJSON *m = cJSON_ParseWithLength((const char *)meta, size);
        const cJSON *g = cJSON_GetObjectItemCaseSensitive(m, "generation");
        const cJSON *s = cJSON_GetObjectItemCaseSensitive(m, "size");
        path_of(p, "scene.bin", path, sizeof path);
        size_t scene_size = 0;
        uint8_t *scene = cJSON_IsNumber(g) && cJSON_IsNumber(s)
                             ? read_file(path, (size_t)s->valuedouble, &scene_size)
                             : NULL;
        if (scene && scene_size == (size_t)s->valuedouble) {
            out->scene = scene;
            out->scene_size = scene_size;
            out->scene_generation = (uint64_t)g->valuedouble;
        } else {
            free(scene);
            keep_aside(p, "scene.json", "does not describe scene.bin");
        }
        cJSON_Delete(m);
        free(meta);
    }
    load_environment(p, out);
    path_of(p, "state.json", path, sizeof path);
    uint8_t *text = read_file(path, 64u << 20, &size);
    if (text) {
        cJSON *doc = cJSON_ParseWithLength((const char *)text, size);
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(doc, "version");
        const cJSON *g = cJSON_GetObjectItemCaseSensitive(doc, "generation");
        const cJSON *src = cJSON_GetObjectItemCaseSensitive(doc, "source");
        cJSON *state = cJSON_DetachItemFromObjectCaseSensitive(doc, "state");
        if (cJSON_IsNumber(v) && v->valuedouble == 1 && cJSON_IsNumber(g) && cJSON_IsString(src) &&
            cJSON_IsObject(state)) {
            out->state = state;
            out->state_generation = (uint64_t)g->valuedouble;
            snprintf(out->state_source, sizeof out->state_source, "%s", src->valuestring);
        } else {
            cJSON_Delete(state);
            keep_aside(p, "state.json", "is not a saved state");
        }
        cJSON_Delete(doc);
        free(text);
    }
}

void srv_saved_free(srv_saved *s)
{
    free(s->scene);
    free(s->environment);
    cJSON_Delete(s->state);
    memset(s, 0, sizeof *s);
}
