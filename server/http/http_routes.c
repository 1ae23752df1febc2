/* http_routes.c: the API's resources (protocol/openapi.yaml): health, frames, uploads, and the
 * JSON resources — GETs from the published snapshot, changes as commands to the render thread. */
#include "server/http/http_internal.h"
#include "server/http/http_response.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <microhttpd.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "server/api/api_json.h"
#include "server/base/clock.h"
#include "server/base/log.h"
#include "server/scene/documents_json.h"
#include "server/scene/scene_state.h"
#include "server/http/stats_report.h"
#include "renderer/gltf/gltf_loader.h"

#define CALL_TIMEOUT_MS 30000
#define FRAME_TIMEOUT_MS 60000 /* GET /v1/frame.jpg waits this long for a frame to be rendered */
#define SCENE_TIMEOUT_MS 300000

/* ---- handlers ------------------------------------------------------------------------------- */

static enum MHD_Result call(srv_http *h, struct MHD_Connection *conn, request *rq, srv_cmd *c,
                            unsigned timeout_ms)
{
    srv_render_call(h->cfg.loop, c, timeout_ms);
    enum MHD_Result r = srv_http_respond_reply(h, conn, rq, c);
    srv_cmd_unref(c);
    return r;
}

void srv_http_stats_snapshot(srv_http *h, srv_stats_snapshot *s)
{
    memset(s, 0, sizeof *s);
    srv_render_get_stats(h->cfg.loop, &s->render);
    srv_encoder_get_stats(h->cfg.encoders, &s->encoder);
    if (h->cfg.ws) srv_ws_get_stats(h->cfg.ws, &s->stream);
    pthread_mutex_lock(&h->counters_mu);
    s->http = h->counters;
    pthread_mutex_unlock(&h->counters_mu);
    srv_admission_counts(&h->admission, &s->http.connections_open, &s->http.connections_refused);
    s->http.connections_per_ip = h->admission.per_ip;
    s->http.idle_timeout_s = h->cfg.timeout_s;
    s->uptime_s = (srv_mono_ms() - h->start_ms) / 1000.0;
    srv_process_memory_read(&s->memory);
}

enum MHD_Result srv_http_handle_health(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    srv_render_stats rs;
    srv_render_get_stats(h->cfg.loop, &rs);
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "status", rs.device_lost ? "degraded" : "ok");
    cJSON_AddStringToObject(j, "version", PROBECAST_VERSION);
    cJSON_AddStringToObject(j, "device", rs.device);
    cJSON_AddNumberToObject(j, "uptime_s", floor(srv_mono_ms() - h->start_ms) / 1000.0);
    cJSON_AddStringToObject(j, "auth", h->token[0] ? "bearer" : "none");
    cJSON *st = cJSON_AddObjectToObject(j, "stream");
    /* /v1/stream answers on this API's own address; "port" names --ws's port when there is one
     * (the same stream, without the relay through the API) */
    unsigned ws_port = h->cfg.ws ? srv_ws_port(h->cfg.ws) : 0;
    cJSON_AddNumberToObject(st, "port", ws_port ? ws_port : h->port);
    cJSON_AddBoolToObject(st, "same_origin", true);
    cJSON_AddStringToObject(st, "path", "/v1/stream");
    cJSON_AddStringToObject(st, "subprotocol", "probecast.v2");
    /* --tls-cert: the stream is wss:// only (and this API https:// only) */
    bool tls = h->cfg.tls_cert_pem != NULL;
    cJSON_AddStringToObject(st, "scheme", tls ? "wss" : "ws");
    cJSON_AddBoolToObject(st, "tls", tls);
    cJSON_AddNumberToObject(st, "http_port", h->port);
    if (rs.device_lost) cJSON_AddStringToObject(j, "error", rs.last_error);
    return srv_http_respond_json(h, conn, rq, rs.device_lost ? 503 : 200, j);
}

/* GET /v1/frame.jpg[?view=ID]: the view's current frame; when it has none, or owes one, the
 * render thread is asked for it and the request waits for its encoding. */
static double frame_after(const cJSON *j)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(j, "after");
    return cJSON_IsNumber(a) && a->valuedouble >= 0 ? a->valuedouble : 0;
}

enum MHD_Result srv_http_handle_frame(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    uint32_t view = 0;
    const char *q = MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, "view");
    if (q && !srv_http_parse_id(q, &view))
        return srv_http_respond_error(h, conn, rq, 400, SRV_ERR_INVALID_FIELD,
                                      "Query 'view' must be a view id (GET /v1/views lists them).");
    srv_cmd *c = srv_cmd_new(SRV_CMD_FRAME_REQUEST);
    c->view = view;
    srv_render_call(h->cfg.loop, c, CALL_TIMEOUT_MS);
    if (c->mail.reply.status != 200) {
        enum MHD_Result r = srv_http_respond_reply(h, conn, rq, c);
        srv_cmd_unref(c);
        return r;
    }
    cJSON *j = cJSON_Parse(c->mail.reply.body ? c->mail.reply.body : "");
    double after = frame_after(j);
    cJSON_Delete(j);
    srv_cmd_unref(c);
    srv_frame *f = srv_encoder_wait_frame(h->cfg.encoders, view, (uint64_t)after, FRAME_TIMEOUT_MS);
    if (!f)
        return srv_http_respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                                      "No frame of view %u was rendered in time.", view);
    const srv_jpeg *jp = srv_frame_best(f);
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(jp->size, jp->data, MHD_RESPMEM_MUST_COPY);
    char id[32], qs[8], vs[16];
    snprintf(id, sizeof id, "%llu", (unsigned long long)f->info.frame_id);
    snprintf(qs, sizeof qs, "%u", jp->quality);
    snprintf(vs, sizeof vs, "%u", f->info.view_id);
    srv_frame_unref(f);
    if (!resp) return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "image/jpeg");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(resp, "X-Frame-Id", id);
    MHD_add_response_header(resp, "X-Frame-Quality", qs);
    MHD_add_response_header(resp, "X-View-Id", vs);
    enum MHD_Result r = MHD_queue_response(conn, 200, resp);
    MHD_destroy_response(resp);
    srv_http_count_status(h, rq, 200);
    rq->responded = true;
    return r;
}

enum MHD_Result srv_http_handle_upload(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    /* ?name=FILE: the file's name, shown by viewers (libmicrohttpd has URL-decoded it) */
    char file_name[SRV_FILE_NAME_MAX] = "";
    const char *qn = MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, "name");
    if (qn && (strlen(qn) > 1024 || !srv_state_clean_file_name(qn, file_name)))
        return srv_http_respond_error(h, conn, rq, 400, SRV_ERR_INVALID_FIELD,
                                      "Query 'name' must be a file name of at most 1024 bytes.");
    rd_scene *scene = calloc(1, sizeof *scene);
    if (!scene) abort();
    char err[512] = "";
    double t0 = srv_mono_ms();
    rd_gltf_result gr = rd_gltf_load_memory(rq->data, rq->len, NULL, NULL, scene, err, sizeof err);
    if (gr != RD_GLTF_OK) {
        free(scene);
        pthread_mutex_lock(&h->counters_mu);
        h->counters.uploads_rejected++;
        pthread_mutex_unlock(&h->counters_mu);
        srv_info("http", "scene upload of %zu bytes rejected: %s", rq->len, err);
        return srv_http_respond_error(h, conn, rq, 422, SRV_ERR_INVALID_GLTF, "%s",
                                      err[0] ? err : rd_gltf_strerror(gr));
    }
    for (uint32_t i = 0; i < scene->warning_count; i++)
        srv_warn("http", "uploaded scene: %s", scene->warnings[i]);
    srv_info("http", "scene upload of %zu bytes parsed in %.0f ms (%llu triangles)", rq->len,
             srv_mono_ms() - t0, (unsigned long long)scene->tri_total);
    /* the BVHs too are built here, on this connection's thread, and the GPU buffers created and
     * their contents staged: the render thread only runs the copies, so viewers keep seeing the
     * old scene meanwhile */
    rd_gpu_scene_prep prep;
    rd_gpu_scene_staged *staged = calloc(1, sizeof *staged);
    if (!staged) abort();
    double t1 = srv_mono_ms();
    rd_vk *vk = srv_render_loop_device(h->cfg.loop);
    rd_vk_result pr = rd_gpu_scene_prepare_device(&prep, scene, !vk->is_cpu, err, sizeof err);
    double t2 = srv_mono_ms();
    if (pr == RD_VK_OK) {
        pr = rd_gpu_scene_stage(vk, staged, scene, &prep, err, sizeof err);
        rd_gpu_scene_prep_destroy(&prep);
    }
    if (pr != RD_VK_OK) {
        free(staged);
        rd_scene_destroy(scene);
        free(scene);
        pthread_mutex_lock(&h->counters_mu);
        h->counters.uploads_rejected++;
        pthread_mutex_unlock(&h->counters_mu);
        bool bad = pr == RD_VK_ERR_UNSUPPORTED || pr == RD_VK_ERR_OUT_OF_MEMORY;
        return srv_http_respond_error(h, conn, rq, bad ? 422 : 500,
                                      bad ? SRV_ERR_INVALID_GLTF : SRV_ERR_GPU, "%s", err);
    }
    srv_info("http", "BVHs of the upload built in %.0f ms, staged for the GPU in %.0f ms", t2 - t1,
             srv_mono_ms() - t2);
    srv_cmd *c = srv_cmd_new(SRV_CMD_REPLACE_SCENE);
    c->scene = scene;
    c->staged = staged;
    snprintf(c->source, sizeof c->source, "upload");
    memcpy(c->file_name, file_name, sizeof c->file_name);
    srv_render_call(h->cfg.loop, c, SCENE_TIMEOUT_MS);
    pthread_mutex_lock(&h->counters_mu);
    if (c->mail.reply.status == 200)
        h->counters.uploads_accepted++;
    else
        h->counters.uploads_rejected++;
    pthread_mutex_unlock(&h->counters_mu);
    if (c->mail.reply.status == 200 && h->cfg.persist) {
        srv_persist_post_scene(h->cfg.persist, c->scene_generation, rq->data, rq->len);
        rq->data = NULL;
        rq->len = rq->cap = 0;
    }
    enum MHD_Result r = srv_http_respond_reply(h, conn, rq, c);
    srv_cmd_unref(c);
    return r;
}

/* PUT /v1/environment: a Radiance .hdr or an OpenEXR .exr (told apart by its first bytes),
 * parsed and reduced here as it is decoded (never on the render thread), becomes the environment
 * (sky_mode image); DELETE drops it. */
enum MHD_Result srv_http_handle_environment(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    srv_cmd *c = srv_cmd_new(SRV_CMD_SET_ENVIRONMENT);
    if (rq->method == M_PUT) {
        char err[256] = "";
        rd_env_image img;
        if (!rd_env_image_parse(rq->data, rq->len, NULL, &img, err, sizeof err)) {
            srv_cmd_unref(c);
            srv_info("http", "environment upload of %zu bytes rejected: %s", rq->len, err);
            return srv_http_respond_error(h, conn, rq, 422, SRV_ERR_INVALID_IMAGE, "%s", err);
        }
        /* converted and staged for the GPU here too, not on the render thread */
        c->env_staged = calloc(1, sizeof *c->env_staged);
        if (!c->env_staged) abort();
        if (rd_world_stage_environment(srv_render_loop_device(h->cfg.loop), c->env_staged, &img,
                                       err, sizeof err) != RD_VK_OK) {
            srv_cmd_unref(c);
            srv_warn("http", "environment upload of %zu bytes not staged: %s", rq->len, err);
            return srv_http_respond_error(h, conn, rq, 500, SRV_ERR_GPU, "%s", err);
        }
    }
    srv_render_call(h->cfg.loop, c, SCENE_TIMEOUT_MS);
    bool ok = c->mail.reply.status == 200 || c->mail.reply.status == 204;
    if (ok && h->cfg.persist) {
        srv_persist_post_environment(h->cfg.persist, rq->method == M_PUT ? rq->data : NULL,
                                     rq->method == M_PUT ? rq->len : 0);
        if (rq->method == M_PUT) {
            rq->data = NULL;
            rq->len = rq->cap = 0;
        }
    }
    enum MHD_Result r = srv_http_respond_reply(h, conn, rq, c);
    srv_cmd_unref(c);
    return r;
}

/* Answers a GET from the published snapshot (never waits for the render thread). */
static enum MHD_Result handle_get(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    srv_snapshot *snap = h->cfg.snapshot;
    char *text = NULL;
    srv_view_info vi;
    switch (rq->route) {
    case R_SCENE:
        text = srv_snapshot_print(snap, SRV_DOC_SCENE, NULL);
        break;
    case R_LIGHTS:
        text = srv_snapshot_print(snap, SRV_DOC_LIGHTS, NULL);
        break;
    case R_SETTINGS:
        text = srv_snapshot_print(snap, SRV_DOC_SETTINGS, NULL);
        break;
    case R_VIEWS:
        text = srv_snapshot_print(snap, SRV_DOC_VIEWS, NULL);
        break;
    case R_ANIMATION:
        text = srv_snapshot_print(snap, SRV_DOC_ANIMATION, NULL);
        break;
    case R_LIGHT:
        text = srv_snapshot_print_light(snap, rq->id);
        if (!text)
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "There is no light with id %u.", rq->id);
        break;
    case R_NODE:
        text = srv_snapshot_print_node(snap, rq->id);
        if (!text)
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "There is no node with id %u.", rq->id);
        break;
    case R_CAMERA:
    case R_VIEW_CAMERA: {
        uint32_t id = rq->route == R_CAMERA ? SRV_DEFAULT_VIEW : rq->id;
        if (!srv_snapshot_view(snap, id, &vi))
            return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND,
                                          "There is no view with id %u.", id);
        text = srv_json_print_delete(srv_json_camera(&vi.camera));
        break;
    }
    default:
        break;
    }
    if (!text)
        return srv_http_respond_error(h, conn, rq, 503, SRV_ERR_UNAVAILABLE,
                                      "The server is still starting.");
    return srv_http_respond(h, conn, rq, 200, "application/json", text, strlen(text));
}

enum MHD_Result srv_http_handle_json_route(srv_http *h, struct MHD_Connection *conn, request *rq)
{
    if (rq->method & (M_GET | M_HEAD)) return handle_get(h, conn, rq);
    srv_api_error e;
    cJSON *body = NULL;
    if (rq->body == BODY_JSON) {
        body = srv_json_parse_object((const char *)rq->data, rq->len, &e);
        if (!body) return srv_http_respond_api_error(h, conn, rq, &e);
    }
    srv_cmd *c = NULL;
    bool ok = true;
    switch (rq->route) {
    case R_CAMERA:
    case R_VIEW_CAMERA:
        c = srv_cmd_new(SRV_CMD_SET_CAMERA);
        c->view = rq->route == R_CAMERA ? SRV_DEFAULT_VIEW : rq->id;
        c->replace = rq->method == M_PUT;
        ok = srv_json_camera_patch(body, &c->camera, &e);
        break;
    case R_VIEW_PICK:
        c = srv_cmd_new(SRV_CMD_PICK);
        c->view = rq->id;
        ok = srv_json_pick_request(body, c->pick, &e);
        break;
    case R_LIGHTS:
        c = srv_cmd_new(SRV_CMD_ADD_LIGHT);
        ok = srv_json_light_patch(body, &c->light, &e);
        break;
    case R_LIGHT:
        c = srv_cmd_new(rq->method == M_DELETE ? SRV_CMD_DELETE_LIGHT : SRV_CMD_PATCH_LIGHT);
        c->id = rq->id;
        if (rq->method == M_PATCH) ok = srv_json_light_patch(body, &c->light, &e);
        break;
    case R_NODE:
        c = srv_cmd_new(SRV_CMD_PATCH_NODE);
        c->id = rq->id;
        ok = srv_json_node_patch(body, &c->node, &e);
        break;
    case R_SETTINGS:
        c = srv_cmd_new(SRV_CMD_PATCH_SETTINGS);
        ok = srv_json_settings_patch(body, &c->settings, &e);
        break;
    case R_ANIMATION:
        c = srv_cmd_new(SRV_CMD_PATCH_ANIMATION);
        ok = srv_json_playback_patch(body, &c->playback, &e);
        break;
    default:
        break;
    }
    cJSON_Delete(body);
    if (!c) return srv_http_respond_error(h, conn, rq, 500, SRV_ERR_INTERNAL, "Unrouted request.");
    if (!ok) {
        srv_cmd_unref(c);
        return srv_http_respond_api_error(h, conn, rq, &e);
    }
    return call(h, conn, rq, c, CALL_TIMEOUT_MS);
}
