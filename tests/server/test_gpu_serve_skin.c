/* A skinned model in the daemon, on lavapipe: the two-bone arm of tests/renderer/skin_builder.h
 * loaded with --scene. GET /v1/scene lists its skin (two joints) and the arm node's skin; seeking
 * the animation (PATCH /v1/animation) rebuilds the arm's bottom-level BVH, which rays traced on
 * the GPU show: picks over the picture hit the straight arm (|y| <= 0.1) at 0 s, the forearm
 * pointing up (hits up to y = 1) at 1.5 s, and the straight arm again back at 0 s (posed and
 * refitted on the GPU by then: GET /v1/stats counts one CPU rebuild and two GPU refits). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/skin_builder.h"
#include "serve_util.h"
#include "test_util.h"

#define GRID_X 24
#define GRID_Y 18

static pc_daemon d = {.token = "s3cret"};

static int patch(const char *method, const char *path, const char *body)
{
    pc_http_response r;
    int s = pc_api(&d, method, path, body, true, &r);
    pc_http_response_free(&r);
    return s;
}

/* Picks a grid over view 0's picture: how many rays hit node `arm` and the largest y of a hit. */
static int pick_grid(int arm, double *max_y)
{
    int hits = 0;
    *max_y = -INFINITY;
    for (int gy = 0; gy < GRID_Y; gy++) {
        for (int gx = 0; gx < GRID_X; gx++) {
            char body[96];
            snprintf(body, sizeof body, "{\"x\":%.6f,\"y\":%.6f}", (gx + 0.5) / GRID_X,
                     (gy + 0.5) / GRID_Y);
            pc_http_response r;
            int status = pc_api(&d, "POST", "/v1/views/0/pick", body, true, &r);
            cJSON *j = cJSON_Parse(r.body ? r.body : "");
            pc_http_response_free(&r);
            CHECK(status == 200);
            if (cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "hit"))) {
                const cJSON *p = cJSON_GetObjectItemCaseSensitive(j, "position");
                CHECK(pc_json_number(j, "node") == arm && cJSON_GetArraySize(p) == 3);
                double y = cJSON_GetArraySize(p) == 3 ? cJSON_GetArrayItem(p, 1)->valuedouble : 0;
                if (y > *max_y) *max_y = y;
                hits++;
            }
            cJSON_Delete(j);
        }
    }
    return hits;
}

int main(void)
{
    const char *path = test_tmp_path("skinned-arm-serve.gltf");
    char *text = gltf_arm_with_camera();
    FILE *f = fopen(path, "w");
    CHECK(f != NULL && fputs(text, f) >= 0 && fclose(f) == 0);
    free(text);
    const char *args[] = {"--no-animate", "--width", "64",     "--height", "48",
                          "--probes",     "2,2,2",   "--rays", "16",       "--token",
                          "s3cret",       "--scene", path,     NULL};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }

    /* the scene document: one skin of two joints, the arm node deformed by it */
    cJSON *scene = pc_api_get_json(&d, "/v1/scene");
    const cJSON *skins = cJSON_GetObjectItemCaseSensitive(scene, "skins");
    CHECKF(cJSON_GetArraySize(skins) == 1 &&
               pc_json_number(cJSON_GetArrayItem(skins, 0), "joint_count") == 2,
           "GET /v1/scene lists the skin");
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(scene, "morph_meshes")) == 0);
    int arm = -1;
    const cJSON *n;
    cJSON_ArrayForEach(n, cJSON_GetObjectItemCaseSensitive(scene, "nodes"))
    {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(n, "name");
        if (cJSON_IsString(nm) && strcmp(nm->valuestring, "arm") == 0) {
            arm = (int)pc_json_number(n, "id");
            CHECK(pc_json_number(n, "skin") == 0);
        }
    }
    CHECK(arm >= 0);
    cJSON_Delete(scene);

    /* the camera of the file, looking at the arm from 4 m */
    CHECK(patch("PUT", "/v1/camera", "{\"position\":[1,0.4,4],\"target\":[1,0.4,0]}") == 200);
    CHECK(patch("PATCH", "/v1/animation", "{\"playing\":false,\"time\":0}") == 200);
    double straight_y, bent_y, again_y;
    int straight = pick_grid(arm, &straight_y);
    CHECK(patch("PATCH", "/v1/animation", "{\"time\":1.5}") == 200);
    int bent = pick_grid(arm, &bent_y);
    CHECK(patch("PATCH", "/v1/animation", "{\"time\":0.25}") == 200);
    CHECK(patch("PATCH", "/v1/animation", "{\"time\":0}") == 200);
    int again = pick_grid(arm, &again_y);
    printf("arm hits: straight %d (max y %.3f), bent %d (max y %.3f), straight again %d\n",
           straight, straight_y, bent, bent_y, again);
    CHECKF(straight > 0 && straight_y <= 0.1 + 1e-4, "the straight arm: %d hits, y up to %g",
           straight, straight_y);
    CHECKF(bent > 0 && bent_y > 0.5 && bent_y <= 1.0 + 1e-4,
           "the bent arm: %d hits, y up to %g (the forearm reaches y = 1)", bent, bent_y);
    CHECKF(again == straight && again_y == straight_y, "back at 0 s: %d hits, y up to %g", again,
           again_y);

    /* /v1/stats: the first pose rebuilt the arm's BVH on the CPU, the later ones refitted it on
     * the GPU (the arm is one leaf: its SAH cost never grows) */
    cJSON *stats = pc_api_get_json(&d, "/v1/stats");
    const cJSON *df = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(stats, "scene"), "deform");
    CHECKF(cJSON_IsObject(df) && pc_json_number(df, "rebuilds") == 1 &&
               pc_json_number(df, "refits") == 2 && pc_json_number(df, "deform_ms") >= 0 &&
               pc_json_number(df, "refit_ms") >= 0 && pc_json_number(df, "deform_build_ms") > 0,
           "/v1/stats reports the deformation: %g rebuilds, %g refits",
           df ? pc_json_number(df, "rebuilds") : -1, df ? pc_json_number(df, "refits") : -1);
    cJSON_Delete(stats);

    CHECK(pc_daemon_alive(&d));
    CHECKF(pc_daemon_stop(&d) == 0, "clean exit after SIGTERM");
    return test_finish();
}
