/* The contract: every operation protocol/openapi.yaml lists exists on the running server and
 * answers only with statuses it documents (a valid request, a malformed body, a missing
 * token, an unknown id), errors in the documented shape; GET /v1/stream upgrades to the
 * WebSocket on the API's own address. Also: /v1/openapi.yaml serves the file itself. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"
#include "ws_client.h"

typedef struct op {
    char path[64];
    char method[8];
    char id[48]; /* operationId */
    int codes[16];
    int ncodes;
} op;

static op ops[64];
static int nops;

/* The spec is written with two-space indents: "  /path:" under paths, "    get:" for an
 * operation and "        'NNN':" for its responses. */
static void parse_spec(const char *text)
{
    bool in_paths = false;
    char path[64] = "";
    op *cur = NULL;
    for (const char *line = text; line && *line;
         line = strchr(line, '\n') ? strchr(line, '\n') + 1 : NULL) {
        size_t len = strcspn(line, "\n");
        char l[256];
        if (len >= sizeof l) len = sizeof l - 1;
        memcpy(l, line, len);
        l[len] = 0;
        if (l[0] != ' ' && l[0] != 0) in_paths = strcmp(l, "paths:") == 0;
        if (!in_paths) continue;
        if (strncmp(l, "  /", 3) == 0 && l[len - 1] == ':') {
            snprintf(path, sizeof path, "%.*s", (int)(len - 3), l + 2);
            cur = NULL;
        } else if (strncmp(l, "    ", 4) == 0 && l[4] != ' ' && l[len - 1] == ':') {
            static const char *methods[] = {"get", "put", "patch", "post", "delete"};
            cur = NULL;
            for (int i = 0; i < 5; i++) {
                if (strncmp(l + 4, methods[i], strlen(methods[i])) == 0 &&
                    l[4 + strlen(methods[i])] == ':' && nops < 64) {
                    cur = &ops[nops++];
                    snprintf(cur->path, sizeof cur->path, "%s", path);
                    for (int k = 0; methods[i][k]; k++)
                        cur->method[k] = (char)(methods[i][k] - 32);
                }
            }
        } else if (cur && strncmp(l, "      operationId: ", 19) == 0) {
            snprintf(cur->id, sizeof cur->id, "%.47s", l + 19);
        } else if (cur && strncmp(l, "        '", 9) == 0 && l[9] != ' ' && cur->ncodes < 16) {
            cur->codes[cur->ncodes++] = atoi(l + 9);
        }
    }
}

static bool documented(const op *o, int status)
{
    for (int i = 0; i < o->ncodes; i++)
        if (o->codes[i] == status) return true;
    return false;
}

static pc_daemon d = {.token = "s3cret"};

/* Sends one request for o and checks the answer is documented (and, if want, equals want). */
static void probe(const op *o, const char *path, const char *type, const void *body, size_t len,
                  bool auth, int want, const char *what)
{
    char headers[256] = "";
    size_t n = 0;
    if (auth)
        n += (size_t)snprintf(headers + n, sizeof headers - n, "Authorization: Bearer s3cret\r\n");
    if (type) snprintf(headers + n, sizeof headers - n, "Content-Type: %s\r\n", type);
    pc_http_response r;
    int status = pc_http("127.0.0.1", d.http_port, o->method, path, headers, body, len, &r, 120000);
    CHECKF(documented(o, status), "%s %s (%s): status %d is not documented", o->method, o->path,
           what, status);
    CHECKF(!want || status == want, "%s %s (%s): status %d, expected %d: %s", o->method, o->path,
           what, status, want, r.body ? r.body : "");
    char ct[128] = "";
    pc_http_header(&r, "Content-Type", ct, sizeof ct);
    if (status >= 400) {
        cJSON *j = cJSON_Parse(r.body ? r.body : "");
        CHECKF(cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "error")) &&
                   cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "message")),
               "%s %s (%s): error body %s", o->method, o->path, what, r.body ? r.body : "");
        cJSON_Delete(j);
    } else if (status != 204 && strncmp(ct, "application/json", 16) == 0) {
        cJSON *j = cJSON_Parse(r.body ? r.body : "");
        CHECKF(cJSON_IsObject(j), "%s %s: body is not a JSON object", o->method, o->path);
        cJSON_Delete(j);
    }
    pc_http_response_free(&r);
}

/* GET /v1/stream is a WebSocket handshake on the API's own address: a plain GET, an upgrade
 * with and without the token and one from a foreign page, each answered with a documented
 * status (101 for the upgrade). */
static void probe_stream(const op *o)
{
    probe(o, o->path, NULL, NULL, 0, true, 400, "not an upgrade");
    static const struct {
        const char *path, *headers, *what;
        int want;
    } cases[] = {
        {"/v1/stream", "Authorization: Bearer s3cret\r\nSec-WebSocket-Protocol: probecast.v2\r\n",
         "upgrade", 101},
        {"/v1/stream?token=s3cret", "Sec-WebSocket-Protocol: probecast.v1\r\n", "query token", 101},
        {"/v1/stream", "Sec-WebSocket-Protocol: probecast.v2\r\n", "no token", 401},
        {"/v1/stream?token=s3cret", "Origin: http://evil.example\r\n", "foreign origin", 403},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pc_ws ws;
        int rc =
            pc_ws_connect(&ws, "127.0.0.1", d.http_port, cases[i].path, cases[i].headers, 10000);
        CHECKF(documented(o, ws.http_status), "GET /v1/stream (%s): status %d is not documented",
               cases[i].what, ws.http_status);
        CHECKF(ws.http_status == cases[i].want && (rc == 0) == (cases[i].want == 101),
               "GET /v1/stream (%s): status %d, expected %d", cases[i].what, ws.http_status,
               cases[i].want);
        pc_ws_close(&ws);
    }
}

/* A valid body for each mutating operation. */
static const char *valid_body(const op *o)
{
    if (strcmp(o->path, "/v1/camera") == 0 || strcmp(o->path, "/v1/views/{id}/camera") == 0)
        return "{\"position\":[0,1.5,4],\"target\":[0,0.5,0],\"fov\":45}";
    if (strcmp(o->path, "/v1/lights") == 0)
        return "{\"type\":\"spot\",\"intensity\":5,\"position\":[0,2,0]}";
    if (strcmp(o->path, "/v1/lights/{id}") == 0) return "{\"color\":[1,0.8,0.6]}";
    if (strcmp(o->path, "/v1/nodes/{id}") == 0) return "{\"rotation\":[0,0.38268343,0,0.9238795]}";
    if (strcmp(o->path, "/v1/settings") == 0) return "{\"exposure\":0.5}";
    if (strcmp(o->path, "/v1/animation") == 0) return "{\"playing\":false,\"time\":0}";
    if (strcmp(o->path, "/v1/views/{id}/pick") == 0) return "{\"x\":0.5,\"y\":0.5}";
    return "{}";
}

static int first_light_id(void)
{
    cJSON *j = pc_api_get_json(&d, "/v1/lights");
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(j, "lights");
    int id = cJSON_GetArraySize(a) > 0 ? (int)pc_json_number(cJSON_GetArrayItem(a, 0), "id") : -1;
    cJSON_Delete(j);
    return id;
}

int main(void)
{
    size_t spec_len;
    char *spec = test_read_text(PROBECAST_SOURCE_DIR "/protocol/openapi.yaml", &spec_len);
    CHECK(spec != NULL);
    if (!spec) return test_finish();
    parse_spec(spec);
    CHECKF(nops >= 23, "%d operations found in the spec", nops);
    /* every operation is named (uniquely) and documents its client errors */
    for (int i = 0; i < nops; i++) {
        int client_errors = 0;
        for (int k = 0; k < ops[i].ncodes; k++)
            client_errors += ops[i].codes[k] >= 400 && ops[i].codes[k] < 500;
        CHECKF(ops[i].id[0] != 0, "%s %s has an operationId", ops[i].method, ops[i].path);
        CHECKF(client_errors > 0, "%s %s documents a 4xx", ops[i].method, ops[i].path);
        for (int k = 0; k < i; k++)
            CHECKF(strcmp(ops[i].id, ops[k].id) != 0, "operationId %s twice", ops[i].id);
    }
    CHECK(strstr(spec, "securitySchemes:") && strstr(spec, "scheme: bearer") &&
          strstr(spec, "license:"));

    const char *args[] = {
        "--no-animate",    "--width", "64",           "--height", "48",      "--probes", "2,2,2",
        "--rays",          "16",      "--hysteresis", "0.5",      "--token", "s3cret",   "--scene",
        "builtin:cornell", NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    /* the served document is the file */
    pc_http_response r;
    CHECK(pc_api(&d, "GET", "/v1/openapi.yaml", NULL, false, &r) == 200);
    CHECK(r.body_len == spec_len && memcmp(r.body, spec, spec_len) == 0);
    pc_http_response_free(&r);
    /* wait for the first frame so that /v1/frame.jpg has one */
    for (int i = 0; i < 600; i++) {
        int s = pc_api(&d, "GET", "/v1/frame.jpg", NULL, true, &r);
        pc_http_response_free(&r);
        if (s == 200) break;
        pc_sleep_ms(100);
    }

    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.3f, &glb_size);
    for (int i = 0; i < nops; i++) {
        const op *o = &ops[i];
        char path[96];
        const char *brace = strchr(o->path, '{');
        const char *after = brace ? strchr(brace, '}') + 1 : ""; /* "/camera" of views */
        int id = strstr(o->path, "/lights/")  ? first_light_id()
                 : strstr(o->path, "/views/") ? 0 /* the default view */
                                              : 1;
        if (brace)
            snprintf(path, sizeof path, "%.*s%d%s", (int)(brace - o->path), o->path, id, after);
        else
            snprintf(path, sizeof path, "%.63s", o->path);
        fprintf(stderr, "checking %s %s (%d documented responses)\n", o->method, path, o->ncodes);
        bool mutating = strcmp(o->method, "GET") != 0;
        if (strcmp(o->path, "/v1/stream") == 0) {
            probe_stream(o);
            continue;
        }
        if (!mutating) {
            probe(o, path, NULL, NULL, 0, true, 200, "valid");
            if (brace) {
                char unknown[96];
                snprintf(unknown, sizeof unknown, "%.*s77777%s", (int)(brace - o->path), o->path,
                         after);
                probe(o, unknown, NULL, NULL, 0, true, 404, "unknown id");
            }
            continue;
        }
        probe(o, path, NULL, NULL, 0, false, 401, "no token");
        if (strcmp(o->path, "/v1/environment") == 0) {
            if (strcmp(o->method, "DELETE") == 0) {
                probe(o, path, NULL, NULL, 0, true, 204, "valid");
                probe(o, path, NULL, NULL, 0, true, 204, "deleted twice (nothing to remove)");
                continue;
            }
            /* a 2 x 1 Radiance file, flat scanline: (1, 0.5, 0.25) and (0, 0, 0) */
            static const char hdr[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
                                      "\x80\x40\x20\x81\x00\x00\x00\x00";
            probe(o, path, "image/vnd.radiance", "#?RADIANCE\n", 11, true, 422, "malformed");
            probe(o, path, "image/png", "x", 1, true, 415, "media type");
            probe(o, path, "image/vnd.radiance", hdr, sizeof hdr - 1, true, 200, "valid");
            continue;
        }
        if (strcmp(o->method, "DELETE") == 0) {
            char unknown[96];
            snprintf(unknown, sizeof unknown, "%.*s77777", (int)(brace - o->path), o->path);
            probe(o, unknown, NULL, NULL, 0, true, 404, "unknown id");
            /* a light of its own to delete */
            CHECK(pc_api(&d, "POST", "/v1/lights", "{\"type\":\"point\"}", true, &r) == 201);
            cJSON *j = cJSON_Parse(r.body);
            snprintf(path, sizeof path, "/v1/lights/%d", (int)pc_json_number(j, "id"));
            cJSON_Delete(j);
            pc_http_response_free(&r);
            probe(o, path, NULL, NULL, 0, true, 204, "valid");
            probe(o, path, NULL, NULL, 0, true, 404, "deleted twice");
            continue;
        }
        if (strcmp(o->path, "/v1/scene") == 0) {
            probe(o, path, "model/gltf+json", "{", 1, true, 422, "malformed");
            probe(o, path, "image/png", "x", 1, true, 415, "media type");
            probe(o, path, "model/gltf-binary", glb, glb_size, true, 200, "valid");
            continue;
        }
        probe(o, path, "application/json", "{", 1, true, 400, "malformed");
        probe(o, path, "text/plain", "{}", 2, true, 415, "media type");
        const char *body = valid_body(o);
        probe(o, path, "application/json", body, strlen(body), true,
              strcmp(o->method, "POST") == 0 && !strstr(o->path, "/pick") ? 201 : 200, "valid");
    }
    free(glb);
    free(spec);
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
