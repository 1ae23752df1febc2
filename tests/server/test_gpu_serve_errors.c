/* probecast serve under bad input: every malformed request gets its documented error and the
 * previous scene keeps rendering; the stream refuses bad handshakes and closes abusive
 * viewers with the documented codes; random garbage never crashes the daemon. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "serve_util.h"
#include "test_util.h"

static pc_daemon d = {.token = "s3cret"};

/* Checks status and that the body is {"error": code, "message": non-empty}. */
static void expect_error(const char *what, pc_http_response *r, int status, const char *code)
{
    cJSON *j = cJSON_Parse(r->body ? r->body : "");
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(j, "error");
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(j, "message");
    CHECKF(r->status == status, "%s: status %d, expected %d (%s)", what, r->status, status,
           r->body ? r->body : "");
    CHECKF(cJSON_IsString(e) && strcmp(e->valuestring, code) == 0,
           "%s: error code in %s, expected %s", what, r->body ? r->body : "(none)", code);
    CHECKF(cJSON_IsString(m) && strlen(m->valuestring) > 5, "%s: no message", what);
    char type[128];
    CHECKF(pc_http_header(r, "Content-Type", type, sizeof type) &&
               strcmp(type, "application/json") == 0,
           "%s: error is not application/json", what);
    cJSON_Delete(j);
    pc_http_response_free(r);
}

static void call(const char *what, const char *method, const char *path, const char *headers,
                 const void *body, size_t len, int status, const char *code)
{
    pc_http_response r;
    char h[512];
    snprintf(h, sizeof h, "Authorization: Bearer s3cret\r\n%s", headers ? headers : "");
    pc_http("127.0.0.1", d.http_port, method, path, h, body, len, &r, 60000);
    expect_error(what, &r, status, code);
}

static void json_call(const char *what, const char *method, const char *path, const char *json,
                      int status, const char *code)
{
    call(what, method, path, "Content-Type: application/json\r\n", json, json ? strlen(json) : 0,
         status, code);
}

static void test_http_errors(void)
{
    json_call("malformed JSON", "PATCH", "/v1/camera", "{\"position\":[0,1,", 400,
              "malformed_json");
    json_call("not an object", "PATCH", "/v1/camera", "[1,2,3]", 400, "malformed_json");
    json_call("empty body", "PATCH", "/v1/settings", NULL, 400, "malformed_json");
    json_call("wrong type", "PATCH", "/v1/camera", "{\"position\":\"here\"}", 400, "invalid_field");
    json_call("wrong type (settings)", "PATCH", "/v1/settings", "{\"width\":\"64\"}", 400,
              "invalid_field");
    json_call("out of range", "PATCH", "/v1/settings", "{\"quality_still\":0}", 400,
              "invalid_field");
    json_call("unknown field", "PATCH", "/v1/settings", "{\"colour\":1}", 400, "invalid_field");
    json_call("PUT camera incomplete", "PUT", "/v1/camera", "{\"fov\":40}", 400, "invalid_field");
    json_call("light without type", "POST", "/v1/lights", "{\"intensity\":1}", 400,
              "invalid_field");
    json_call("unknown light id", "PATCH", "/v1/lights/999", "{\"intensity\":1}", 404, "not_found");
    call("unknown light id (GET)", "GET", "/v1/lights/999", NULL, NULL, 0, 404, "not_found");
    call("bad light id", "GET", "/v1/lights/abc", NULL, NULL, 0, 404, "not_found");
    call("unknown light id (DELETE)", "DELETE", "/v1/lights/4294967295", NULL, NULL, 0, 404,
         "not_found");
    json_call("unknown node", "PATCH", "/v1/nodes/99", "{\"translation\":[0,0,0]}", 404,
              "not_found");
    json_call("zero scale", "PATCH", "/v1/nodes/1", "{\"scale\":[1,0,1]}", 400, "invalid_field");
    json_call("too many probes", "PATCH", "/v1/settings", "{\"probe_counts\":[256,256,256]}", 400,
              "invalid_field");
    call("form body", "PATCH", "/v1/camera", "Content-Type: application/x-www-form-urlencoded\r\n",
         "a=b", 3, 415, "unsupported_media_type");
    char *big = malloc(70001);
    memset(big, ' ', 70000);
    big[0] = '{';
    big[69999] = '}';
    big[70000] = 0;
    json_call("JSON body too large", "PATCH", "/v1/settings", big, 413, "payload_too_large");
    free(big);
    call("method", "POST", "/v1/camera", NULL, NULL, 0, 405, "method_not_allowed");
    call("route", "GET", "/v1/nothing", NULL, NULL, 0, 404, "not_found");

    /* uploads */
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0, &glb_size);
    call("truncated glb", "PUT", "/v1/scene", "Content-Type: model/gltf-binary\r\n", glb,
         glb_size / 2, 422, "invalid_gltf");
    call("no content type", "PUT", "/v1/scene", NULL, glb, glb_size, 415, "unsupported_media_type");
    call("text content type", "PUT", "/v1/scene", "Content-Type: text/plain\r\n", glb, glb_size,
         415, "unsupported_media_type");
    call("huge upload (Content-Length)", "PUT", "/v1/scene", "Content-Type: model/gltf-binary\r\n",
         NULL, (size_t)300 << 20, 413, "payload_too_large");
    /* --max-upload is 64K here: a chunked body without a length is counted as it arrives */
    size_t chunk = 16384, chunks = 6;
    char *body = malloc(chunks * (chunk + 16) + 8), *p = body;
    for (size_t i = 0; i < chunks; i++) {
        p += sprintf(p, "%zx\r\n", chunk);
        memset(p, 'x', chunk);
        p += chunk;
        p += sprintf(p, "\r\n");
    }
    p += sprintf(p, "0\r\n\r\n");
    call("huge upload (chunked)", "PUT", "/v1/scene",
         "Content-Type: model/gltf-binary\r\nTransfer-Encoding: chunked\r\n", body,
         (size_t)(p - body), 413, "payload_too_large");
    free(body);
    const char *bad_index =
        "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[5]}],\"nodes\":[]}";
    call("invalid glTF", "PUT", "/v1/scene", "Content-Type: model/gltf+json\r\n", bad_index,
         strlen(bad_index), 422, "invalid_gltf");
    const char *external = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":4,"
                           "\"uri\":\"/etc/passwd\"}]}";
    call("external URI", "PUT", "/v1/scene", "Content-Type: model/gltf+json\r\n", external,
         strlen(external), 422, "invalid_gltf");
    call("not JSON at all", "PUT", "/v1/scene", "Content-Type: model/gltf+json\r\n", "hello", 5,
         422, "invalid_gltf");

    /* the token */
    pc_http_response r;
    pc_http("127.0.0.1", d.http_port, "PATCH", "/v1/camera", "Content-Type: application/json\r\n",
            "{}", 2, &r, 60000);
    expect_error("missing token", &r, 401, "unauthorized");
    pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
            "Content-Type: model/gltf-binary\r\nAuthorization: Bearer nope\r\n", glb, glb_size, &r,
            60000);
    expect_error("wrong token", &r, 401, "unauthorized");
    pc_http("127.0.0.1", d.http_port, "DELETE", "/v1/lights/0", NULL, NULL, 0, &r, 60000);
    expect_error("missing token (DELETE)", &r, 401, "unauthorized");
    free(glb);

    /* static files: no way out of the web folder */
    const char *escapes[] = {"/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/.git/config",
                             "/web/../CMakeLists.txt"};
    for (size_t i = 0; i < sizeof escapes / sizeof *escapes; i++) {
        pc_http("127.0.0.1", d.http_port, "GET", escapes[i], NULL, NULL, 0, &r, 60000);
        CHECKF(r.status == 404 && !strstr(r.body ? r.body : "", "root:"), "%s -> %d", escapes[i],
               r.status);
        pc_http_response_free(&r);
    }
    pc_http("127.0.0.1", d.http_port, "GET", "/", NULL, NULL, 0, &r, 60000);
    CHECK(r.status == 200 && strstr(r.body, "<html"));
    pc_http_response_free(&r);
}

static void test_stream_refusals(void)
{
    pc_ws ws;
    char path[128];
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream", NULL, 10000) != 0);
    CHECKF(ws.http_status == 401, "no token: %d", ws.http_status);
    pc_ws_close(&ws);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=wrong", NULL, 10000) != 0);
    pc_ws_close(&ws);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/other?token=s3cret", NULL, 10000) != 0);
    pc_ws_close(&ws);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret",
                        "Origin: http://evil.example:8080\r\n", 10000) != 0);
    CHECKF(ws.http_status == 403, "foreign origin: %d", ws.http_status);
    pc_ws_close(&ws);
    char origin[128];
    /* a page of another port on this host is another origin */
    snprintf(origin, sizeof origin, "Origin: http://127.0.0.1:%u\r\n", d.http_port + 1);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret", origin, 10000) !=
          0);
    pc_ws_close(&ws);
    /* accepted: same-origin page; subprotocol token; Authorization header */
    snprintf(origin, sizeof origin, "Origin: http://localhost:%u\r\n", d.http_port);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret", origin, 10000) ==
          0);
    pc_ws_close(&ws);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream",
                        "Sec-WebSocket-Protocol: probecast.v1, bearer.s3cret\r\n", 10000) == 0);
    pc_ws_close(&ws);
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream",
                        "Authorization: Bearer s3cret\r\n", 10000) == 0);
    pc_ws_close(&ws);
    (void)path;
}

/* Sends one abusive message and expects the close code. */
static void expect_close(const char *what, int opcode, const void *data, size_t len, int code)
{
    pc_ws ws;
    CHECK(pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret", NULL, 10000) == 0);
    CHECK(pc_ws_send_frame(&ws, opcode, data, len, true) == 0);
    double deadline = pc_now_ms() + 30000;
    int op = 0;
    while (pc_now_ms() < deadline) {
        uint8_t *m;
        size_t l;
        op = pc_ws_recv(&ws, 30000, &m, &l);
        if (op == 8 || op < 0) break;
    }
    CHECKF(op == 8 && ws.close_code == code, "%s: opcode %d close code %d (expected %d)", what, op,
           ws.close_code, code);
    pc_ws_close(&ws);
}

static void test_stream_abuse(void)
{
    expect_close("binary message", 2, "\x01\x02", 2, 1003);
    expect_close("not JSON", 1, "{camera", 7, 1008);
    expect_close("unknown type", 1, "{\"type\":\"shell\"}", 16, 1008);
    expect_close("wrong field type", 1, "{\"type\":\"camera\",\"seq\":\"1\"}", 27, 1008);
    char big[6000];
    memset(big, ' ', sizeof big);
    memcpy(big, "{\"type\":\"ack\",\"frame\":1}", 24);
    expect_close("oversized message", 1, big, sizeof big, 1009);
}

/* Random bytes and mutated JSON at every input: the daemon must stay up. */
static void test_garbage(void)
{
    const char *seeds[] = {"{\"position\":[0,1,2],\"target\":[0,0,0]}",
                           "{\"type\":\"spot\",\"intensity\":3}", "{\"width\":64,\"height\":48}",
                           "{\"translation\":[1,2,3]}"};
    const char *paths[] = {"/v1/camera", "/v1/lights", "/v1/settings", "/v1/nodes/1"};
    const char *methods[] = {"PATCH", "POST", "PATCH", "PATCH"};
    srand(1234);
    pc_ws ws;
    bool open =
        pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret", NULL, 10000) == 0;
    for (int i = 0; i < 120; i++) {
        int k = i % 4;
        char buf[256];
        snprintf(buf, sizeof buf, "%s", seeds[k]);
        size_t len = strlen(buf);
        for (int m = 0; m < 1 + rand() % 4; m++)
            buf[rand() % len] = (char)(rand() % 256);
        pc_http_response r;
        pc_http("127.0.0.1", d.http_port, methods[k], paths[k],
                "Authorization: Bearer s3cret\r\nContent-Type: application/json\r\n", buf, len, &r,
                60000);
        CHECKF(r.status == 200 || r.status == 201 || r.status == 400 || r.status == 404,
               "garbage -> %d", r.status);
        pc_http_response_free(&r);
        if (open && i % 3 == 0) {
            char msg[300];
            snprintf(msg, sizeof msg, "{\"type\":\"camera\",\"seq\":%d,%s", i, buf + 1);
            if (pc_ws_send_text(&ws, msg) != 0) {
                pc_ws_close(&ws);
                open = pc_ws_connect(&ws, "127.0.0.1", d.ws_port, "/v1/stream?token=s3cret", NULL,
                                     10000) == 0;
            }
        }
    }
    if (open) pc_ws_close(&ws);
    /* a raw non-HTTP blob on both ports */
    for (int port = 0; port < 2; port++) {
        pc_http_response r;
        pc_http("127.0.0.1", port ? d.ws_port : d.http_port, "\x01\x02GARBAGE", "/\xff\xfe",
                "X: \x7f\r\n", NULL, 0, &r, 5000);
        pc_http_response_free(&r);
    }
    CHECK(pc_daemon_alive(&d));
}

/* Sends a raw request (for a Host header of our choosing) and returns the status. */
static int raw_status(unsigned port, const char *request)
{
    int fd = pc_dial("127.0.0.1", port, 10000);
    if (fd < 0) return -1;
    int status = -1;
    if (pc_send_all(fd, request, strlen(request)) == 0) {
        char buf[256];
        ssize_t n = recv(fd, buf, sizeof buf - 1, 0);
        if (n > 12) {
            buf[n] = 0;
            sscanf(buf, "HTTP/1.%*d %d", &status);
        }
    }
    close(fd);
    return status;
}

/* DNS rebinding and foreign pages: a Host that is not a name of this server is refused on every
 * route and on the stream; a change from another page's Origin is refused. */
static void test_foreign_hosts(void)
{
    char req[512];
    snprintf(req, sizeof req,
             "POST /v1/lights HTTP/1.1\r\nHost: evil.example:%u\r\nOrigin: http://evil.example:%u"
             "\r\nAuthorization: Bearer s3cret\r\nContent-Type: application/json\r\n"
             "Content-Length: 16\r\nConnection: close\r\n\r\n{\"type\":\"point\"}",
             d.http_port, d.http_port);
    CHECK(raw_status(d.http_port, req) == 403);
    snprintf(req, sizeof req,
             "GET /v1/scene HTTP/1.1\r\nHost: evil.example:%u\r\nConnection: close\r\n\r\n",
             d.http_port);
    CHECK(raw_status(d.http_port, req) == 403);
    snprintf(req, sizeof req,
             "GET / HTTP/1.1\r\nHost: evil.example:%u\r\nConnection: close\r\n\r\n", d.http_port);
    CHECK(raw_status(d.http_port, req) == 403);
    /* an IP address or a loopback name is fine */
    snprintf(req, sizeof req,
             "GET /v1/scene HTTP/1.1\r\nHost: localhost:%u\r\nConnection: close\r\n\r\n",
             d.http_port);
    CHECK(raw_status(d.http_port, req) == 200);
    /* a change from a foreign page, Host ours */
    snprintf(req, sizeof req,
             "POST /v1/lights HTTP/1.1\r\nHost: 127.0.0.1:%u\r\nOrigin: http://evil.example"
             "\r\nAuthorization: Bearer s3cret\r\nContent-Type: application/json\r\n"
             "Content-Length: 16\r\nConnection: close\r\n\r\n{\"type\":\"point\"}",
             d.http_port);
    CHECK(raw_status(d.http_port, req) == 403);
    call("foreign origin", "PATCH", "/v1/settings",
         "Content-Type: application/json\r\nOrigin: http://evil.example\r\n", "{}", 2, 403,
         "forbidden");
    /* the stream */
    snprintf(req, sizeof req,
             "GET /v1/stream?token=s3cret HTTP/1.1\r\nHost: evil.example:%u\r\nUpgrade: "
             "websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: "
             "dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
             d.ws_port);
    CHECK(raw_status(d.ws_port, req) == 403);
}

int main(void)
{
    const char *args[] = {
        "--no-animate", "--width",         "64",     "--height",     "48",
        "--probes",     "2,2,2",           "--rays", "16",           "--hysteresis",
        "0.5",          "--token",         "s3cret", "--max-upload", "64K",
        "--scene",      "builtin:cornell", NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    /* the scene that must survive every bad upload */
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.8f, &glb_size);
    pc_http_response r;
    CHECK(pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                  "Authorization: Bearer s3cret\r\nContent-Type: model/gltf-binary\r\n", glb,
                  glb_size, &r, 120000) == 200);
    pc_http_response_free(&r);
    free(glb);
    /* the .gltf form (data: URI buffer) is accepted too */
    char *gltf = pc_make_gltf(0.5f);
    CHECK(pc_http("127.0.0.1", d.http_port, "PUT", "/v1/scene",
                  "Authorization: Bearer s3cret\r\nContent-Type: model/gltf+json\r\n", gltf,
                  strlen(gltf), &r, 120000) == 200);
    pc_http_response_free(&r);
    free(gltf);
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    double generation = pc_json_number(scene, "generation");
    CHECK(generation == 2 && pc_json_number(scene, "triangles") == 14);
    cJSON_Delete(scene);

    test_http_errors();
    test_stream_refusals();
    test_stream_abuse();
    test_garbage();
    test_foreign_hosts();

    /* the previous scene is still there and still renders */
    scene = pc_api_get_json(&d, "/v1/scene");
    CHECK(pc_json_number(scene, "generation") == generation &&
          pc_json_number(scene, "triangles") == 14);
    cJSON_Delete(scene);
    pc_ws ws;
    CHECK(pc_stream_open(&d, &ws));
    CHECK(pc_ws_send_text(
              &ws,
              "{\"type\":\"camera\",\"seq\":4242,\"position\":[0,2,5],\"target\":[0,0.5,0]}") == 0);
    bool seen = false;
    double deadline = pc_now_ms() + 60000;
    while (!seen && pc_now_ms() < deadline) {
        pc_frame f;
        if (!pc_stream_next(&ws, 60000, true, &f)) break;
        seen = f.h.input_seq == 4242 && f.mean > 5;
        pc_frame_free(&f);
    }
    CHECK(seen);
    pc_ws_close(&ws);
    cJSON *stats = pc_api_get_json(&d, "/v1/stats");
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(stats, "stream");
    CHECK(pc_json_number(st, "connections_rejected") >= 4);
    CHECK(pc_json_number(st, "connections_closed_for_abuse") >= 5);
    cJSON_Delete(stats);
    CHECK(pc_daemon_alive(&d));
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
