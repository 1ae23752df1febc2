/* probecast serve: the daemon. Parses options, restores saved state, starts the render thread,
 * the encoder pool, the frame stream and the HTTP API, waits for SIGINT/SIGTERM and shuts
 * everything down in order. */
#include <arpa/inet.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "server/serve.h"
#include "server/base/args.h"
#include "server/encode/encoder_pool.h"
#include "server/http/http_api.h"
#include "server/base/log.h"
#include "server/scene/persist.h"
#include "server/render/render_loop.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/builtin/procedural.h"
#include "server/scene/scene_state.h"
#include "server/scene/snapshot.h"
#include "server/http/tls_cert.h"
#include "server/stream/ws_stream.h"

#define DEMO_SCENE "builtin:cornell"

static void serve_usage(FILE *f)
{
    fprintf(
        f,
        "usage: probecast serve [OPTIONS]\n"
        "\n"
        "Runs the daemon: renders a scene with global illumination and streams it to browsers.\n"
        "Open the printed http:// (or https://) address in a browser. Stop with Ctrl-C (SIGINT)\n"
        "or SIGTERM.\n"
        "\n"
        "Options:\n"
        "  --scene FILE|builtin:NAME  scene at start-up (default: the demo, builtin:cornell,\n"
        "                         whose light circles slowly while someone watches)\n"
        "  --http ADDR:PORT       HTTP API and viewer (default 127.0.0.1:8080; port 0 = any)\n"
        "  --ws ADDR:PORT         also serve the WebSocket frame stream on a port of its own\n"
        "                         (default: none; it is always at /v1/stream of --http)\n"
        "  --token T              require 'Authorization: Bearer T' for changes, frames and the\n"
        "                         stream (default: $PROBECAST_TOKEN; needed off loopback)\n"
        "  --tls-cert FILE        serve the API over https:// and the stream over wss:// only,\n"
        "                         with this PEM certificate (chain), for use without a TLS\n"
        "                         proxy; needs --tls-key\n"
        "  --tls-key FILE         the certificate's PEM private key, without a passphrase\n"
        "  --public-name NAME     a host name (or NAME:PORT's NAME) browsers use to reach this\n"
        "                         server, besides loopback names and IP addresses; repeatable.\n"
        "                         Requests naming any other Host are refused (DNS rebinding)\n"
        "  --data-dir DIR         keep the last uploaded scene, camera, lights and settings\n"
        "                         in DIR and restore them at start-up (a saved upload is\n"
        "                         used instead of --scene)\n"
        "  --max-upload BYTES     largest scene upload, with optional K, M or G suffix\n"
        "                         (default 256M)\n"
        "  --max-viewers N        stream connections in all (default 100)\n"
        "  --max-viewers-per-ip N stream connections per client address (default 64)\n"
        "  --http-connections N   HTTP connections in all (default 64; 16 per address)\n"
        "  --idle-timeout S       seconds an HTTP connection may send nothing before it is\n"
        "                         closed (default 30)\n"
        "  --max-views N          views in all: the default view and one per viewer of stream\n"
        "                         protocol 2 (default 64, at most 256)\n"
        "  --max-total-pixels N   pixels over all views (default 16777216)\n"
        "  --web-dir DIR          viewer files served at / (default: web/ of the source tree)\n"
        "  --encoders N           JPEG encoder threads (default: the CPU cores, 2 to 16)\n"
        "  --vp9-speed N          VP9 viewers' encoder speed, 5 (better) to 9 (faster)\n"
        "                         (default 9: libvpx's cpu-used)\n"
        "  --video-threads N      threads of each video viewer's encoder (default: one a\n"
        "                         million pixels, 1 to 4)\n"
        "  --jpeg auto|gpu|cpu    where JPEGs are transformed and quantised: gpu (a compute\n"
        "                         pass; the encoders only entropy-code), cpu (libjpeg-turbo\n"
        "                         encodes the pixels); auto: gpu unless the device is the CPU\n"
        "                         (lavapipe) (default: $PROBECAST_JPEG, else auto)\n"
        "  --device INDEX|NAME    Vulkan device (default: $PROBECAST_DEVICE, else the best)\n"
        "  --log-level L          error, warn, info (default) or debug ($PROBECAST_LOG)\n"
        "  --help                 this text\n"
        "\n"
        "Settings at start-up (GET and PATCH /v1/settings while it runs):\n");
    srv_settings_print_usage(f, SRV_CLI_SERVE);
    fprintf(f, "  --animate, --no-animate  the light animation (default: on for the demo scene "
               "only)\n");
}

typedef struct serve_args {
    const char *scene, *http, *ws, *token, *data_dir, *web_dir, *device;
    const char *tls_cert, *tls_key; /* both or neither */
    char public_names[1024];        /* --public-name values, comma-separated */
    size_t max_upload;
    unsigned max_viewers, max_per_ip, http_connections, idle_timeout, encoders, max_views,
        max_total_pixels;
    unsigned vp9_speed, video_threads; /* 0: the encoder's defaults */
    srv_settings settings;
    unsigned given; /* SRV_SET_* chosen on the command line */
    int animate;    /* -1 default, 0 off, 1 on */
    srv_jpeg_path jpeg;
    bool jpeg_given;
} serve_args;

static bool parse_size(const char *opt, const char *v, size_t *out)
{
    char *end = NULL;
    errno = 0;
    unsigned long long n = strtoull(v, &end, 10);
    unsigned long long mul = 1;
    if (end && *end) {
        if (strcmp(end, "K") == 0 || strcmp(end, "k") == 0)
            mul = 1ull << 10;
        else if (strcmp(end, "M") == 0 || strcmp(end, "m") == 0)
            mul = 1ull << 20;
        else if (strcmp(end, "G") == 0 || strcmp(end, "g") == 0)
            mul = 1ull << 30;
        else
            mul = 0;
    }
    if (!*v || v[0] == '-' || errno || mul == 0 || n == 0 || n > (1ull << 40) / mul) {
        fprintf(stderr,
                "probecast: %s expects a size in bytes such as 268435456 or 256M, got '%s'\n", opt,
                v);
        return false;
    }
    *out = (size_t)(n * mul);
    return true;
}

/* "ADDR:PORT" or "[ADDR6]:PORT" with a numeric address ("localhost" means 127.0.0.1). */
static bool parse_addr(const char *opt, const char *v, char *host, size_t hostlen, unsigned *port)
{
    const char *colon = NULL;
    size_t hl;
    const char *h = v;
    if (v[0] == '[') {
        const char *rb = strchr(v, ']');
        if (!rb || rb[1] != ':') goto bad;
        h = v + 1;
        hl = (size_t)(rb - v - 1);
        colon = rb + 1;
    } else {
        colon = strrchr(v, ':');
        if (!colon) goto bad;
        hl = (size_t)(colon - v);
    }
    if (hl == 0 || hl >= hostlen) goto bad;
    memcpy(host, h, hl);
    host[hl] = 0;
    if (strcmp(host, "localhost") == 0) snprintf(host, hostlen, "127.0.0.1");
    unsigned char buf[16];
    if (inet_pton(AF_INET, host, buf) != 1 && inet_pton(AF_INET6, host, buf) != 1) goto bad;
    if (!srv_arg_uint(opt, colon + 1, 0, 65535, port)) return false;
    return true;
bad:
    fprintf(
        stderr,
        "probecast: %s expects ADDR:PORT with a numeric address (e.g. 127.0.0.1:8080), got '%s'\n",
        opt, v);
    return false;
}

static bool is_loopback(const char *host)
{
    return strncmp(host, "127.", 4) == 0 || strcmp(host, "::1") == 0;
}

/* Returns -1 when parsing succeeded, else the exit status to use. */
static int parse(int argc, char **argv, serve_args *a)
{
    memset(a, 0, sizeof *a);
    a->http = "127.0.0.1:8080";
    a->ws = NULL; /* the stream is at /v1/stream of --http's address; --ws adds a port */
    a->animate = -1;
    srv_settings_defaults(&a->settings);
    srv_settings *s = &a->settings;
    for (int i = 1; i < argc; i++) {
        int setting =
            srv_settings_parse_flag("probecast serve", SRV_CLI_SERVE, argc, argv, &i, s, &a->given);
        if (setting < 0) return 2;
        if (setting > 0) continue;
        const char *o = argv[i];
        const char *v = NULL;
#define NEED_VALUE                                                                                 \
    if (!(v = srv_arg_value("probecast serve", argc, argv, &i))) return 2;
#define IS(name) (strcmp(o, name) == 0)
        if (IS("--help") || IS("-h")) {
            serve_usage(stdout);
            return 0;
        } else if (IS("--animate")) {
            a->animate = 1;
        } else if (IS("--no-animate")) {
            a->animate = 0;
        } else if (IS("--scene")) {
            NEED_VALUE a->scene = v;
        } else if (IS("--http")) {
            NEED_VALUE a->http = v;
        } else if (IS("--ws")) {
            NEED_VALUE a->ws = v;
        } else if (IS("--token")) {
            NEED_VALUE a->token = v;
        } else if (IS("--tls-cert")) {
            NEED_VALUE a->tls_cert = v;
        } else if (IS("--tls-key")) {
            NEED_VALUE a->tls_key = v;
        } else if (IS("--public-name")) {
            NEED_VALUE if (!*v || strlen(v) > 200 || strchr(v, ',') ||
                           strlen(a->public_names) + strlen(v) + 2 > sizeof a->public_names)
            {
                fprintf(stderr, "probecast serve: --public-name expects a host name\n");
                return 2;
            }
            if (a->public_names[0]) strcat(a->public_names, ",");
            strcat(a->public_names, v);
        } else if (IS("--data-dir")) {
            NEED_VALUE a->data_dir = v;
        } else if (IS("--web-dir")) {
            NEED_VALUE a->web_dir = v;
        } else if (IS("--device")) {
            NEED_VALUE a->device = v;
        } else if (IS("--max-upload")) {
            NEED_VALUE if (!parse_size(o, v, &a->max_upload)) return 2;
        } else if (IS("--max-viewers")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 10000, &a->max_viewers)) return 2;
        } else if (IS("--max-viewers-per-ip")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 10000, &a->max_per_ip)) return 2;
        } else if (IS("--max-views")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 256, &a->max_views)) return 2;
        } else if (IS("--max-total-pixels")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 256, 4000000000u, &a->max_total_pixels)) return 2;
        } else if (IS("--http-connections")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 10000, &a->http_connections)) return 2;
        } else if (IS("--idle-timeout")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 3600, &a->idle_timeout)) return 2;
        } else if (IS("--encoders")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 64, &a->encoders)) return 2;
        } else if (IS("--vp9-speed")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 5, 9, &a->vp9_speed)) return 2;
        } else if (IS("--video-threads")) {
            NEED_VALUE if (!srv_arg_uint(o, v, 1, 16, &a->video_threads)) return 2;
        } else if (IS("--jpeg")) {
            NEED_VALUE
            a->jpeg_given = true;
            if (!srv_jpeg_path_parse(v, &a->jpeg)) {
                fprintf(stderr, "probecast serve: --jpeg expects auto, gpu or cpu\n");
                return 2;
            }
        } else if (IS("--log-level")) {
            NEED_VALUE
            srv_log_level lv;
            if (!srv_log_parse_level(v, &lv)) {
                fprintf(stderr,
                        "probecast serve: --log-level expects error, warn, info or debug\n");
                return 2;
            }
            srv_log_set_level(lv);
        } else {
            fprintf(stderr, "probecast serve: unknown option '%s' (see --help)\n", o);
            return 2;
        }
#undef NEED_VALUE
#undef IS
    }
    if (!a->tls_cert != !a->tls_key) {
        fprintf(stderr, "probecast serve: %s needs %s too (TLS takes a certificate and its key)\n",
                a->tls_cert ? "--tls-cert" : "--tls-key", a->tls_cert ? "--tls-key" : "--tls-cert");
        return 2;
    }
    if ((uint64_t)s->width * s->height > s->max_pixels) s->max_pixels = s->width * s->height;
    return -1;
}

/* A file next to the executable's folder (the source tree when run from build/), else in the
 * working folder; NULL when neither exists. */
static const char *find_resource(const char *rel, char *out, size_t outlen)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    struct stat sb;
    if (n > 0) {
        exe[n] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = 0;
            int k = snprintf(out, outlen, "%s/../%s", exe, rel);
            if (k > 0 && (size_t)k < outlen && stat(out, &sb) == 0) return out;
            k = snprintf(out, outlen, "%s/%s", exe, rel);
            if (k > 0 && (size_t)k < outlen && stat(out, &sb) == 0) return out;
        }
    }
    snprintf(out, outlen, "%s", rel);
    return stat(out, &sb) == 0 ? out : NULL;
}

/* The start-up scene: the saved upload when there is one, else --scene, else the demo. */
static bool load_start_scene(const serve_args *a, srv_saved *saved, rd_scene *scene, char *source,
                             size_t sourcelen, uint64_t *generation)
{
    if (saved->scene) {
        char err[512];
        if (rd_gltf_load_memory(saved->scene, saved->scene_size, NULL, NULL, scene, err,
                                sizeof err) == RD_GLTF_OK) {
            snprintf(source, sourcelen, "upload");
            *generation = saved->scene_generation;
            srv_info("serve", "restored the uploaded scene (generation %llu) from %s%s",
                     (unsigned long long)*generation, a->data_dir,
                     a->scene ? "; --scene is ignored" : "");
            return true;
        }
        srv_warn("serve", "the saved scene no longer loads (%s); using %s", err,
                 a->scene ? a->scene : DEMO_SCENE);
    }
    const char *spec = a->scene ? a->scene : DEMO_SCENE;
    if (!srv_arg_scene(spec, scene)) return false;
    snprintf(source, sourcelen, "%s", spec);
    *generation = 0;
    return true;
}

int srv_serve(int argc, char **argv)
{
    serve_args a;
    int status = parse(argc, argv, &a);
    if (status >= 0) return status;
    srv_log_level lv;
    const char *env_log = getenv("PROBECAST_LOG");
    if (env_log && srv_log_parse_level(env_log, &lv)) srv_log_set_level(lv);
    if (!a.token) a.token = getenv("PROBECAST_TOKEN");
    const char *env_jpeg = getenv("PROBECAST_JPEG");
    if (!a.jpeg_given && env_jpeg && *env_jpeg && !srv_jpeg_path_parse(env_jpeg, &a.jpeg)) {
        fprintf(stderr, "probecast serve: PROBECAST_JPEG expects auto, gpu or cpu\n");
        return 2;
    }
    if (a.token && !*a.token) a.token = NULL;
    if (a.token) {
        for (const char *p = a.token; *p; p++) {
            if (!((*p >= 'A' && *p <= 'Z') || (*p >= 'a' && *p <= 'z') ||
                  (*p >= '0' && *p <= '9') || strchr("-._~", *p)) ||
                strlen(a.token) > 200) {
                fprintf(
                    stderr,
                    "probecast serve: the token may hold only A-Z a-z 0-9 - . _ ~ (at most 200)\n");
                return 2;
            }
        }
    }
    char http_host[64], ws_host[64] = "";
    unsigned http_port, ws_port = 0;
    if (!parse_addr("--http", a.http, http_host, sizeof http_host, &http_port) ||
        (a.ws && !parse_addr("--ws", a.ws, ws_host, sizeof ws_host, &ws_port)))
        return 2;
    if ((!is_loopback(http_host) || (a.ws && !is_loopback(ws_host))) && !a.token)
        srv_warn("serve",
                 "listening beyond loopback without --token: anyone who reaches this host can "
                 "change the scene and watch the stream");
    /* TLS: the files are read and checked now, before the GPU starts; they stay in memory until
     * the end (the HTTP API keeps using the PEM text) */
    srv_tls_cert tls;
    memset(&tls, 0, sizeof tls);
    const bool use_tls = a.tls_cert != NULL;
    if (use_tls) {
        char tls_err[768];
        if (!srv_http_tls_available()) {
            fprintf(stderr, "probecast serve: --tls-cert needs a libmicrohttpd built with TLS "
                            "(GnuTLS), and this one has none\n");
            return 2;
        }
        if (srv_tls_cert_load(&tls, a.tls_cert, a.tls_key, tls_err, sizeof tls_err) != SRV_TLS_OK) {
            fprintf(stderr, "probecast serve: %s\n", tls_err);
            return 2;
        }
        time_t now = time(NULL);
        char until[32] = "?";
        struct tm tm;
        if (tls.not_after && gmtime_r(&tls.not_after, &tm))
            strftime(until, sizeof until, "%Y-%m-%d %H:%M UTC", &tm);
        srv_info("serve", "TLS certificate %s (%s), valid until %s", a.tls_cert, tls.subject,
                 until);
        if (tls.not_after && now > tls.not_after)
            srv_warn("serve", "the --tls-cert certificate expired on %s: browsers will refuse it",
                     until);
        else if (tls.not_before && now < tls.not_before)
            srv_warn("serve",
                     "the --tls-cert certificate is not valid yet: browsers will refuse it");
    }

    /* Every thread created from here on inherits this mask; the main thread takes the signals
     * with sigwait. */
    sigset_t sigs;
    sigemptyset(&sigs);
    sigaddset(&sigs, SIGINT);
    sigaddset(&sigs, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &sigs, NULL);
    signal(SIGPIPE, SIG_IGN);

    char err[512] = "";
    srv_persist *persist = NULL;
    srv_saved saved;
    memset(&saved, 0, sizeof saved);
    if (a.data_dir) {
        persist = srv_persist_open(a.data_dir, err, sizeof err);
        if (!persist) {
            fprintf(stderr, "probecast serve: %s\n", err);
            srv_tls_cert_dispose(&tls);
            return 1;
        }
        srv_persist_load(persist, &saved);
    }
    rd_scene scene;
    char source[128];
    uint64_t generation = 0;
    if (!load_start_scene(&a, &saved, &scene, source, sizeof source, &generation)) {
        srv_persist_close(persist);
        srv_saved_free(&saved);
        srv_tls_cert_dispose(&tls);
        return 1;
    }
    const cJSON *state = NULL;
    if (saved.state && saved.state_generation == generation &&
        strcmp(saved.state_source, source) == 0)
        state = saved.state;
    else if (saved.state)
        srv_info("serve",
                 "the saved camera, lights and settings belong to another scene; not applied");
    if (a.animate < 0) a.animate = strcmp(source, DEMO_SCENE) == 0;
    a.settings.animate = a.animate == 1;

    int rc = 1;
    srv_encoder_pool *enc = NULL;
    srv_snapshot *snap = srv_snapshot_create();
    srv_render_loop *loop = NULL;
    srv_ws_stream *ws = NULL;
    srv_http *http = NULL;
    /* default: one encoder per core (large frames are striped over all of them), 2 to 16 */
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    unsigned default_encoders = cores < 2 ? 2u : cores > 16 ? 16u : (unsigned)cores;
    enc = srv_encoder_pool_create(a.encoders ? a.encoders : default_encoders);
    if (!enc) {
        fprintf(stderr, "probecast serve: cannot start the JPEG encoders\n");
        rd_scene_destroy(&scene);
        goto out;
    }
    srv_render_config rc_cfg = {
        .device = a.device,
        .settings = a.settings,
        .encoders = enc,
        .jpeg_path = a.jpeg,
        .snapshot = snap,
        .persist = persist,
        .max_views = a.max_views,
        .max_total_pixels = a.max_total_pixels,
        .generation_base = saved.scene_generation,
        .adapt_to_cpu = true,
        .settings_given = a.given,
    };
    loop = srv_render_loop_create(&rc_cfg, &scene, source, generation, state, err, sizeof err);
    if (!loop) {
        fprintf(stderr, "probecast serve: %s\n", err);
        goto out;
    }
    srv_ws_config ws_cfg = {
        .address = a.ws ? ws_host : NULL,
        .port = ws_port,
        .token = a.token,
        .public_names = a.public_names,
        .http_host = http_host,
        .max_viewers = a.max_viewers,
        .max_per_ip = a.max_per_ip,
        .tls_cert_path = use_tls ? a.tls_cert : NULL,
        .tls_key_path = use_tls ? a.tls_key : NULL,
        .loop = loop,
        .encoders = enc,
        .snapshot = snap,
        .vp9_speed = a.vp9_speed,
        .video_threads = a.video_threads,
    };
    ws = srv_ws_create(&ws_cfg, err, sizeof err);
    if (!ws) {
        fprintf(stderr, "probecast serve: %s\n", err);
        goto out;
    }
    char web_buf[PATH_MAX], api_buf[PATH_MAX];
    srv_http_config http_cfg = {
        .address = http_host,
        .port = http_port,
        .token = a.token,
        .public_names = a.public_names,
        .max_upload = a.max_upload,
        .max_connections = a.http_connections,
        .timeout_s = a.idle_timeout,
        .stream_viewers = a.max_viewers ? a.max_viewers : 100,
        .stream_per_ip = a.max_per_ip ? a.max_per_ip : 64,
        .web_dir = a.web_dir ? a.web_dir : find_resource("web", web_buf, sizeof web_buf),
        .openapi_path = find_resource("protocol/openapi.yaml", api_buf, sizeof api_buf),
        .tls_cert_pem = tls.cert_pem,
        .tls_key_pem = tls.key_pem,
        .loop = loop,
        .encoders = enc,
        .ws = ws,
        .snapshot = snap,
        .persist = persist,
    };
    http = srv_http_start(&http_cfg, err, sizeof err);
    if (!http) {
        fprintf(stderr, "probecast serve: %s\n", err);
        goto out;
    }
    srv_ws_set_http_port(ws, srv_http_port(http));
    srv_encoder_pool_set_listener(enc, srv_ws_frame_ready, ws);
    srv_snapshot_set_listener(snap, srv_ws_event_ready, ws);
    /* the saved environment image comes back before the first frame (the render loop takes
     * commands in order) */
    if (saved.environment) {
        rd_env_image img;
        char env_err[256];
        srv_cmd *c = srv_cmd_new(SRV_CMD_SET_ENVIRONMENT);
        c->env_staged = calloc(1, sizeof *c->env_staged);
        if (!c->env_staged) abort();
        if (rd_env_image_parse(saved.environment, saved.environment_size, NULL, &img, env_err,
                               sizeof env_err) &&
            rd_world_stage_environment(srv_render_loop_device(loop), c->env_staged, &img, env_err,
                                       sizeof env_err) == RD_VK_OK) {
            srv_render_post(loop, c); /* takes c */
        } else {
            srv_warn("serve", "the saved environment image no longer loads (%s); not used",
                     env_err);
            srv_cmd_unref(c);
        }
    }
    if (!srv_render_loop_start(loop) || !srv_ws_start(ws)) {
        fprintf(stderr, "probecast serve: cannot start threads\n");
        goto out;
    }
    const char *hb = strchr(http_host, ':') ? "[" : "", *he = strchr(http_host, ':') ? "]" : "";
    /* the stream's address: --ws's port when given, else the API's own (/v1/stream there) */
    const char *stream_host = a.ws ? ws_host : http_host;
    unsigned stream_port = a.ws ? srv_ws_port(ws) : srv_http_port(http);
    const char *wb = strchr(stream_host, ':') ? "[" : "", *we = strchr(stream_host, ':') ? "]" : "";
    /* https=/wss= instead of http=/ws= with --tls-cert: nothing answers plain requests then */
    const char *hs = use_tls ? "https" : "http", *ss = use_tls ? "wss" : "ws";
    printf("probecast serving %s=%s%s%s:%u %s=%s%s%s:%u\n", hs, hb, http_host, he,
           srv_http_port(http), ss, wb, stream_host, we, stream_port);
    printf("open %s://%s%s%s:%u/%s in a browser (stream: %s://%s%s%s:%u/v1/stream)\n", hs, hb,
           strcmp(http_host, "0.0.0.0") == 0 ? "127.0.0.1" : http_host, he, srv_http_port(http),
           a.token ? "?token=..." : "", ss, wb, stream_host, we, stream_port);
    fflush(stdout);
    srv_info("serve", "serving %s on %s %s:%u, stream %s%s:%u/v1/stream%s", source, hs, http_host,
             srv_http_port(http), use_tls ? "wss " : "", stream_host, stream_port,
             a.ws ? " and on the API's address" : "");

    int sig = 0;
    sigwait(&sigs, &sig);
    srv_info("serve", "%s received: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
    rc = 0;

out:
    /* stop accepting; stop producing frames; close viewers; finish HTTP requests (they get 503
     * from the stopped render loop); drain encoders; flush the disk; then the GPU */
    srv_http_quiesce(http);
    srv_render_loop_stop(loop);
    if (enc) srv_encoder_pool_set_listener(enc, NULL, NULL);
    srv_snapshot_set_listener(snap, NULL, NULL);
    srv_ws_destroy(ws);
    srv_http_stop(http);
    srv_encoder_pool_destroy(enc);
    srv_persist_close(persist);
    unsigned validation = srv_render_loop_validation_messages(loop);
    srv_render_loop_destroy(loop);
    srv_snapshot_destroy(snap);
    if (validation > 0 && rc == 0) {
        srv_error("serve", "%u Vulkan validation message(s) during this run", validation);
        rc = 1;
    }
    srv_saved_free(&saved);
    srv_tls_cert_dispose(&tls); /* after srv_http_stop: the daemon held the PEM text */
    if (rc == 0) srv_info("serve", "stopped cleanly");
    return rc;
}
