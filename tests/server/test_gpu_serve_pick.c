/* POST /v1/views/{id}/pick: one camera ray traced on the GPU through a point of a view's picture
 * names the node under it. The reference is independent of the daemon's GPU path: the same
 * .glb loaded here, its instances' triangles placed in world space on the CPU and traced with
 * rd_bvh_closest_triangle along the ray the view's camera (GET /v1/views/0/camera) gives the
 * point. A grid of points over the picture must agree (hit or miss, node, distance, position)
 * before and after PATCH /v1/nodes/{id} moves the box. Bad requests answer 4xx, and the upload's
 * ?name= is cleaned and reported as the scene's file_name. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/bvh.h"
#include "renderer/scene/camera.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/xform.h"
#include "serve_util.h"
#include "server/api/commands.h"
#include "test_util.h"

#define GRID 6

static pc_daemon d;

/* The scene's triangles in world space, with the node each belongs to. */
typedef struct soup {
    float *pos;
    uint32_t *node;
    uint32_t count;
    rd_bvh bvh;
} soup;

static void soup_build(soup *s, const rd_scene *sc)
{
    memset(s, 0, sizeof *s);
    for (uint32_t i = 0; i < sc->instance_count; i++)
        s->count += sc->meshes[sc->instances[i].mesh].tri_count;
    s->pos = malloc((size_t)s->count * 9 * sizeof *s->pos);
    s->node = malloc((size_t)s->count * sizeof *s->node);
    uint32_t k = 0;
    for (uint32_t i = 0; i < sc->instance_count; i++) {
        const rd_mesh *m = &sc->meshes[sc->instances[i].mesh];
        const float *w = sc->nodes[sc->instances[i].node].world;
        for (uint32_t t = 0; t < m->tri_count; t++, k++) {
            for (int v = 0; v < 3; v++)
                rd_mat4_transform_point(w, &m->positions[t * 9 + v * 3], &s->pos[k * 9 + v * 3]);
            s->node[k] = sc->instances[i].node;
        }
    }
    CHECK(rd_bvh_build_triangles(&s->bvh, s->pos, s->count, NULL));
}

static void soup_free(soup *s)
{
    rd_bvh_destroy(&s->bvh);
    free(s->pos);
    free(s->node);
}

static bool vec_of(const cJSON *o, const char *name, float *out, int n)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, name);
    if (cJSON_GetArraySize(a) != n) return false;
    for (int i = 0; i < n; i++)
        out[i] = (float)cJSON_GetArrayItem(a, i)->valuedouble;
    return true;
}

/* The ray of picture point (x, y) of view 0, from its camera and size as the API reports them. */
static bool view_ray(float x, float y, float org[3], float dir[3])
{
    cJSON *cam = pc_api_get_json(&d, "/v1/views/0/camera");
    cJSON *views = pc_api_get_json(&d, "/v1/views");
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(views, "views");
    const cJSON *v0 = NULL, *it;
    cJSON_ArrayForEach(it, list)
    {
        if (pc_json_number(it, "id") == 0) v0 = it;
    }
    rd_view_camera c;
    bool ok = cam && v0 && vec_of(cam, "position", c.eye, 3) &&
              vec_of(cam, "forward", c.forward, 3) && vec_of(cam, "up", c.up, 3);
    if (ok) {
        c.yfov = (float)(pc_json_number(cam, "fov") * M_PI / 180.0);
        pc_view pv;
        rd_camera_to_view(&c, (unsigned)pc_json_number(v0, "width"),
                          (unsigned)pc_json_number(v0, "height"), &pv);
        float nx = 2 * x - 1, ny = 1 - 2 * y, len = 0;
        const float f[3] = {pv.forward.x, pv.forward.y, pv.forward.z};
        const float r[3] = {pv.right.x, pv.right.y, pv.right.z};
        const float u[3] = {pv.up.x, pv.up.y, pv.up.z};
        for (int k = 0; k < 3; k++) {
            dir[k] = f[k] + nx * r[k] + ny * u[k];
            len += dir[k] * dir[k];
            org[k] = c.eye[k];
        }
        for (int k = 0; k < 3; k++)
            dir[k] /= sqrtf(len);
    }
    cJSON_Delete(cam);
    cJSON_Delete(views);
    return ok;
}

static cJSON *pick(const char *path, float x, float y, int *status)
{
    char body[96];
    snprintf(body, sizeof body, "{\"x\":%.6f,\"y\":%.6f}", (double)x, (double)y);
    pc_http_response r;
    *status = pc_api(&d, "POST", path, body, false, &r);
    cJSON *j = cJSON_Parse(r.body ? r.body : "");
    pc_http_response_free(&r);
    return j;
}

/* Picks a grid of points and compares each answer with the CPU trace of scene sc. Returns the
 * number of hits on node `count_node` and of misses through the counters. */
static void compare_grid(const rd_scene *sc, const char *what, uint32_t count_node, int *node_hits,
                         int *misses)
{
    soup s;
    soup_build(&s, sc);
    *node_hits = *misses = 0;
    for (int gy = 0; gy < GRID; gy++) {
        for (int gx = 0; gx < GRID; gx++) {
            float x = (gx + 0.5f) / GRID, y = (gy + 0.5f) / GRID;
            if (gx == 0 && gy == GRID - 1) x = 0, y = 1; /* a corner exactly */
            float org[3], dir[3], t = 0;
            CHECK(view_ray(x, y, org, dir));
            int64_t tri = rd_bvh_closest_triangle(&s.bvh, s.pos, org, dir, 0, 1e30f, &t);
            int status;
            cJSON *j = pick("/v1/views/0/pick", x, y, &status);
            const cJSON *hit = cJSON_GetObjectItemCaseSensitive(j, "hit");
            CHECKF(status == 200 && cJSON_IsBool(hit), "%s (%g, %g): status %d", what, (double)x,
                   (double)y, status);
            CHECKF(cJSON_IsTrue(hit) == (tri >= 0), "%s (%g, %g): GPU %s, CPU %s", what, (double)x,
                   (double)y, cJSON_IsTrue(hit) ? "hit" : "miss", tri >= 0 ? "hit" : "miss");
            if (tri < 0) {
                (*misses)++;
            } else if (cJSON_IsTrue(hit)) {
                uint32_t node = s.node[tri];
                *node_hits += node == count_node;
                CHECKF(pc_json_number(j, "node") == node, "%s (%g, %g): node %g, CPU %u", what,
                       (double)x, (double)y, pc_json_number(j, "node"), node);
                const cJSON *name = cJSON_GetObjectItemCaseSensitive(j, "node_name");
                CHECK(cJSON_IsString(name) && strcmp(name->valuestring, sc->nodes[node].name) == 0);
                CHECK(pc_json_number(j, "mesh") == sc->nodes[node].mesh);
                CHECK(pc_json_number(j, "instance") >= 0 &&
                      pc_json_number(j, "instance") < sc->instance_count);
                double dist = pc_json_number(j, "distance");
                CHECKF(fabs(dist - t) <= 1e-3 * t, "%s (%g, %g): distance %g, CPU %g", what,
                       (double)x, (double)y, dist, (double)t);
                float p[3], n[3];
                CHECK(vec_of(j, "position", p, 3) && vec_of(j, "normal", n, 3));
                for (int k = 0; k < 3; k++)
                    CHECKF(fabsf(p[k] - (org[k] + t * dir[k])) <= 2e-3f, "%s: position[%d]", what,
                           k);
                /* the normal faces the camera */
                CHECK(n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2] < 0);
            }
            cJSON_Delete(j);
        }
    }
    soup_free(&s);
}

static void expect_status(const char *method, const char *path, const char *body, int want,
                          const char *what)
{
    pc_http_response r;
    int status = pc_api(&d, method, path, body, false, &r);
    cJSON *j = cJSON_Parse(r.body ? r.body : "");
    CHECKF(status == want, "%s: status %d, expected %d: %s", what, status, want,
           r.body ? r.body : "");
    if (status >= 400)
        CHECKF(cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "error")) &&
                   cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "message")),
               "%s: error body", what);
    cJSON_Delete(j);
    pc_http_response_free(&r);
}

static int upload(const uint8_t *glb, size_t size, const char *query)
{
    char path[2200];
    snprintf(path, sizeof path, "/v1/scene%s", query);
    pc_http_response r;
    int status = pc_http("127.0.0.1", d.http_port, "PUT", path,
                         "Content-Type: model/gltf-binary\r\n", glb, size, &r, 120000);
    pc_http_response_free(&r);
    return status;
}

static void expect_file_name(const char *want)
{
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *fn = cJSON_GetObjectItemCaseSensitive(scene, "file_name");
    CHECKF(cJSON_IsString(fn) && strcmp(fn->valuestring, want) == 0, "file_name '%s', want '%s'",
           cJSON_IsString(fn) ? fn->valuestring : "(none)", want);
    cJSON_Delete(scene);
}

int main(void)
{
    const char *args[] = {"--no-animate", "--width", "64",     "--height", "48",
                          "--probes",     "2,2,2",   "--rays", "16",       NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    size_t glb_size;
    uint8_t *glb = pc_make_glb(0.0f, &glb_size);
    CHECK(upload(glb, glb_size, "?name=scenes%2Fbox%20%26%20floor.glb") == 200);
    expect_file_name("box & floor.glb");

    /* the same scene on the CPU */
    rd_scene sc;
    char err[256];
    CHECK(rd_gltf_load_memory(glb, glb_size, NULL, NULL, &sc, err, sizeof err) == RD_GLTF_OK);
    CHECK(rd_scene_update(&sc, err, sizeof err));
    CHECK(sc.node_count == 4 && sc.instance_count == 2 && strcmp(sc.nodes[1].name, "box") == 0);

    /* looking slightly down at the box: box, floor and sky are all in the picture */
    pc_http_response r;
    CHECK(pc_api(&d, "PUT", "/v1/camera", "{\"position\":[0.2,1.2,3.5],\"target\":[0,0.4,0]}",
                 false, &r) == 200);
    pc_http_response_free(&r);
    int box_hits, misses;
    compare_grid(&sc, "before", 1, &box_hits, &misses);
    CHECKF(box_hits > 0 && misses > 0, "the grid sees the box (%d) and the sky (%d)", box_hits,
           misses);

    /* the centre is on the box: its front face at z = 0.5 */
    int status;
    cJSON *j = pick("/v1/views/0/pick", 0.5f, 0.5f, &status);
    CHECK(status == 200 && cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "hit")) &&
          pc_json_number(j, "node") == 1);
    cJSON_Delete(j);

    /* a ray exactly through the box's centre (a zero direction component, and the origin of
     * the instance's object space): the primary pass hits it, so must the pick */
    CHECK(pc_api(&d, "PUT", "/v1/camera", "{\"position\":[0,1.2,3.5],\"target\":[0,0.5,0]}", false,
                 &r) == 200);
    pc_http_response_free(&r);
    j = pick("/v1/views/0/pick", 0.5f, 0.5f, &status);
    CHECKF(status == 200 && pc_json_number(j, "node") == 1 &&
               fabs(pc_json_number(j, "distance") - (sqrt(0.7 * 0.7 + 3.5 * 3.5) * 3.0 / 3.5)) <
                   1e-3,
           "the centre ray hits the box's front face");
    cJSON_Delete(j);
    CHECK(pc_api(&d, "PUT", "/v1/camera", "{\"position\":[0.2,1.2,3.5],\"target\":[0,0.4,0]}",
                 false, &r) == 200);
    pc_http_response_free(&r);

    /* bad requests */
    expect_status("POST", "/v1/views/0/pick", "{", 400, "malformed JSON");
    expect_status("POST", "/v1/views/0/pick", "[0.5,0.5]", 400, "not an object");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":0.5}", 400, "y missing");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":1.5,\"y\":0.5}", 400, "x out of range");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":0.5,\"y\":-0.1}", 400, "y out of range");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":\"0.5\",\"y\":0.5}", 400, "x a string");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":0.5,\"y\":0.5,\"z\":1}", 400,
                  "unknown field");
    expect_status("POST", "/v1/views/0/pick", "{\"x\":0.5,\"x\":0.5,\"y\":0.5}", 400,
                  "duplicate key");
    expect_status("POST", "/v1/views/77777/pick", "{\"x\":0.5,\"y\":0.5}", 404, "unknown view");
    expect_status("POST", "/v1/views/abc/pick", "{\"x\":0.5,\"y\":0.5}", 404, "not a view id");
    expect_status("GET", "/v1/views/0/pick", NULL, 405, "GET");
    expect_status("POST", "/v1/views/0/picks", "{\"x\":0.5,\"y\":0.5}", 404, "no such resource");

    /* move the box right and turn it: picking follows the new top-level BVH */
    CHECK(pc_api(&d, "PATCH", "/v1/nodes/1",
                 "{\"translation\":[0.9,0.5,-0.3],\"rotation\":[0,0.38268343,0,0.9238795]}", false,
                 &r) == 200);
    pc_http_response_free(&r);
    /* GET /v1/scene lists the node where it is now */
    cJSON *doc = pc_api_get_json(&d, "/v1/scene");
    float moved[3] = {0, 0, 0};
    CHECK(vec_of(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(doc, "nodes"), 1),
                 "translation", moved, 3) &&
          moved[0] == 0.9f && moved[1] == 0.5f && moved[2] == -0.3f);
    cJSON_Delete(doc);
    const float t[3] = {0.9f, 0.5f, -0.3f}, q[4] = {0, 0.38268343f, 0, 0.9238795f};
    memcpy(sc.nodes[1].translation, t, sizeof t);
    memcpy(sc.nodes[1].rotation, q, sizeof q);
    CHECK(rd_scene_update(&sc, err, sizeof err));
    compare_grid(&sc, "after", 1, &box_hits, &misses);
    CHECK(box_hits > 0);
    /* the centre now looks past the box's left side, onto the floor */
    j = pick("/v1/views/0/pick", 0.5f, 0.5f, &status);
    CHECK(status == 200 && pc_json_number(j, "node") == 0);
    cJSON_Delete(j);

    /* file names: directories dropped, control characters replaced, long names cut; a name
     * too long to be one is refused and the scene stays */
    CHECK(upload(glb, glb_size, "?name=..%2F..%2Fa%01b.glb") == 200);
    expect_file_name("a_b.glb");
    CHECK(upload(glb, glb_size, "?name=%C3%A9t%C3%A9%FF.glb") == 200);
    expect_file_name("\xc3\xa9t\xc3\xa9_.glb");
    char q2[2100] = "?name=";
    memset(q2 + 6, 'n', 300);
    q2[306] = 0;
    CHECK(upload(glb, glb_size, q2) == 200);
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *fn = cJSON_GetObjectItemCaseSensitive(scene, "file_name");
    CHECK(cJSON_IsString(fn) && strlen(fn->valuestring) == SRV_FILE_NAME_MAX - 1);
    cJSON_Delete(scene);
    memset(q2 + 6, 'n', 2000);
    q2[2006] = 0;
    CHECK(upload(glb, glb_size, q2) == 400);
    CHECK(upload(glb, glb_size, "") == 200);
    expect_file_name("");

    rd_scene_destroy(&sc);
    free(glb);
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
