/* test_skin.c: glTF skins and morph targets, from files written here in memory (JSON with a base64
 * buffer) through the loader, animation sampling and rd_scene_update's CPU deformation
 * (renderer/scene/deform.h) to the vertices the BVH builder gets: a two-bone arm bent 90 degrees
 * (positions, normals and tangents against hand-computed values), a cube with two morph targets
 * and animated weights (STEP, LINEAR, CUBICSPLINE), weights that do not sum to one (warning,
 * normalised) and a joint index outside the skin (a clear error). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_scene.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/animation_clip.h"
#include "renderer/scene/deform.h"
#include "renderer/scene/xform.h"
#include "skin_builder.h"
#include "test_util.h"

static char err[512];

static rd_gltf_result load(char *text, rd_scene *s)
{
    err[0] = '\0';
    rd_gltf_result r = rd_gltf_load_memory(text, strlen(text), NULL, NULL, s, err, sizeof err);
    free(text);
    return r;
}

static int near(float a, double b, double tol)
{
    return fabs((double)a - b) <= tol;
}

static int near3(const float *a, const double *b, double tol)
{
    return near(a[0], b[0], tol) && near(a[1], b[1], tol) && near(a[2], b[2], tol);
}

static uint32_t node_named(const rd_scene *s, const char *name)
{
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].name && strcmp(s->nodes[i].name, name) == 0) return i;
    CHECKF(0, "no node '%s'", name);
    return 0;
}

static void pose(rd_scene *s, double t)
{
    rd_scene_animate(s, t);
    CHECKF(rd_scene_update(s, err, sizeof err), "%s", err);
}

/* Where glTF vertex v of the arm is at angle a of the elbow (blend: the middle vertices' elbow
 * weight): the shoulder leaves p alone, the elbow turns it about (1, 0) by a. */
static void arm_expected(int v, double a, double blend, double out[3])
{
    const float *p = &kArmPos[v * 3];
    double x = p[0] - 1, y = p[1];
    double e[3] = {1 + x * cos(a) - y * sin(a), x * sin(a) + y * cos(a), 0};
    double we = v < 2 ? 0 : v < 4 ? blend : 1;
    for (int k = 0; k < 3; k++)
        out[k] = (1 - we) * p[k] + we * e[k];
}

/* Every corner of the arm's mesh, placed by its node, against arm_expected; normals stay +Z,
 * tangents of the elbow's vertices turn with it. */
static void check_arm(const rd_scene *s, double a, double blend, double tol, int line)
{
    const rd_mesh *m = &s->meshes[0];
    const float *world = s->nodes[node_named(s, "arm")].world;
    int bad = 0;
    for (uint32_t c = 0; c < m->tri_count * 3; c++) {
        int v = kArmIdx[c];
        double e[3];
        arm_expected(v, a, blend, e);
        float w[3];
        rd_mat4_transform_point(world, &m->positions[c * 3], w);
        const double up[3] = {0, 0, 1};
        bad += !near3(w, e, tol) || !near3(&m->normals[c * 3], up, 1e-5);
        if (v >= 4) {
            const double t[3] = {cos(a), sin(a), 0};
            bad += !near3(&m->tangents[c * 4], t, 1e-5) || m->tangents[c * 4 + 3] != 1.0f;
        }
        if (bad == 1 && !near3(w, e, tol))
            fprintf(stderr, "corner %u (vertex %d): (%g %g %g), expected (%g %g %g)\n", c, v,
                    (double)w[0], (double)w[1], (double)w[2], e[0], e[1], e[2]);
    }
    CHECKF(bad == 0, "arm at %g degrees: %d corners off (test line %d)", a * 180 / M_PI, bad, line);
}

static void test_arm(void)
{
    rd_scene s;
    CHECKF(load(gltf_arm(ARM_FLOAT), &s) == RD_GLTF_OK, "%s", err);
    CHECK(s.warning_count == 0);
    CHECK(s.skin_count == 1 && s.skins[0].joint_count == 2);
    CHECK(s.mesh_count == 1 && s.meshes[0].deform && s.meshes[0].deform->influences == 4);
    CHECK(s.nodes[node_named(&s, "arm")].skin == 1);
    check_arm(&s, 0, 0.5, 1e-5, __LINE__); /* bind pose: the mesh node's z = 5 is ignored */
    uint64_t rev = s.meshes[0].deform->revision;
    pose(&s, 0.5);
    check_arm(&s, M_PI / 4, 0.5, 1e-5, __LINE__);
    pose(&s, 1.5);
    check_arm(&s, M_PI / 2, 0.5, 1e-5, __LINE__);
    /* hand-computed: the tip (2, 0.1) turns about the elbow to (0.9, 1); the middle vertex
     * (1, 0.1) halfway between itself and (0.9, 0) */
    const float *w = s.nodes[node_named(&s, "arm")].world;
    float p[3];
    rd_mat4_transform_point(w, &s.meshes[0].positions[8 * 3], p); /* corner 8 = vertex 5 */
    CHECK(near3(p, (const double[3]){0.9, 1, 0}, 1e-5));
    rd_mat4_transform_point(w, &s.meshes[0].positions[3 * 3], p); /* corner 3 = vertex 0 */
    CHECK(near3(p, (const double[3]){0, -0.1, 0}, 1e-6));
    rd_mat4_transform_point(w, &s.meshes[0].positions[2 * 3], p); /* corner 2 = vertex 3 */
    CHECK(near3(p, (const double[3]){0.95, 0.05, 0}, 1e-5));
    /* only a change of pose deforms again */
    uint64_t rev2 = s.meshes[0].deform->revision;
    CHECK(rev2 > rev);
    pose(&s, 1.75);
    CHECK(s.meshes[0].deform->revision == rev2);
    /* the BVHs the renderer builds see the bent arm (its box reaches y = 1) */
    rd_gpu_scene_prep prep;
    CHECK(rd_gpu_scene_prepare(&prep, &s, err, sizeof err) == RD_VK_OK);
    CHECK(near(prep.mesh_bounds[4], 1.0, 1e-4) && near(prep.mesh_bounds[5], -5.0, 1e-4));
    rd_gpu_scene_prep_destroy(&prep);
    rd_scene_destroy(&s);

    /* a second set of influences: eight per vertex, the elbow's half in JOINTS_1 */
    CHECKF(load(gltf_arm(ARM_TWO_SETS), &s) == RD_GLTF_OK, "%s", err);
    CHECK(s.warning_count == 0 && s.meshes[0].deform && s.meshes[0].deform->influences == 8);
    pose(&s, 0.5);
    check_arm(&s, M_PI / 4, 0.5, 1e-5, __LINE__);
    rd_scene_destroy(&s);

    /* unsigned short joints, normalized unsigned byte weights (128/255 on the elbow) */
    CHECKF(load(gltf_arm(ARM_NORMALIZED), &s) == RD_GLTF_OK, "%s", err);
    CHECK(s.warning_count == 0);
    pose(&s, 0.5);
    check_arm(&s, M_PI / 4, 127.0 / 255.0, 1e-5, __LINE__);
    rd_scene_destroy(&s);
}

static void test_bad_skins(void)
{
    /* weights summing to 0.5: one warning, then the same arm as normalised weights give */
    rd_scene s;
    CHECKF(load(gltf_arm(ARM_HALF_WEIGHTS), &s) == RD_GLTF_OK, "%s", err);
    CHECKF(s.warning_count == 1 && strstr(s.warnings[0], "12 skinned triangle corners have joint "
                                                         "weights that do not sum to one"),
           "%s", s.warning_count ? s.warnings[0] : "no warning");
    pose(&s, 0.5);
    check_arm(&s, M_PI / 4, 0.5, 1e-5, __LINE__);
    rd_scene_destroy(&s);

    /* a vertex bound to joint 5 of a skin of two joints */
    CHECK(load(gltf_arm(ARM_BAD_JOINT), &s) == RD_GLTF_ERR_INVALID);
    CHECKF(strstr(err, "mesh 0 has a vertex bound to joint 5, but skin 0 (of node 0) has only 2 "
                       "joints"),
           "%s", err);
    CHECK(s.meshes == NULL && s.nodes == NULL && s.skins == NULL);

    /* broken skins: every one an error with a message, never a crash */
    static const struct {
        const char *from, *to, *needle;
    } edits[] = {
        {"'skin':0", "'skin':3", "refers to skin 3, but there are only 1 skins"},
        {"'joints':[1,2]", "'joints':[1,9]", "joint 1 is node 9, but there are only 3 nodes"},
        {"'inverseBindMatrices':6", "'inverseBindMatrices':7", "has type SCALAR, expected MAT4"},
        {"'JOINTS_0':4", "'JOINTS_0':5", "component type 5126"},
        {"'WEIGHTS_0':5", "'WEIGHTS_0':4", "holds integers but is not normalized"},
        {"'JOINTS_0':4,", "", "has WEIGHTS_0 without JOINTS_0"},
        {"'joints':[1,2]", "'joints':[]", "skin 0 has 0 joints"},
    };
    for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++) {
        char *text = gltf_arm(ARM_FLOAT);
        char from[128], to[128];
        snprintf(from, sizeof from, "%s", edits[i].from);
        snprintf(to, sizeof to, "%s", edits[i].to);
        for (char *q = from; *q; q++)
            if (*q == '\'') *q = '"';
        for (char *q = to; *q; q++)
            if (*q == '\'') *q = '"';
        char *at = strstr(text, from);
        CHECKF(at != NULL, "edit %zu: '%s' not in the file", i, from);
        if (!at) {
            free(text);
            continue;
        }
        char *edited = test_xprintf("%.*s%s%s", (int)(at - text), text, to, at + strlen(from));
        free(text);
        rd_gltf_result r = load(edited, &s);
        CHECKF(r != RD_GLTF_OK && strstr(err, edits[i].needle), "edit %zu: %s", i, err);
        CHECK(s.meshes == NULL && s.nodes == NULL);
    }
}

/* ---- the morphing cube (skin_builder.h) --------------------------------------------------- */

/* Node `name`'s weights are (w0, w1), its mesh's top corner (glTF vertex 7 = (1, 1, 1)) moved
 * to (1 + w0, 1, 1 + 2 w1), its top face's normals tilted to (w1, 0, 1) and tangents to
 * (1, w1, 0), normalised. */
static void check_cube(const rd_scene *s, const char *name, double w0, double w1, int line)
{
    const rd_node *n = &s->nodes[node_named(s, name)];
    CHECKF(n->weight_count == 2 && near(n->weights[0], w0, 1e-5) && near(n->weights[1], w1, 1e-5),
           "%s weights (%g %g), expected (%g %g) (test line %d)", name,
           n->weight_count ? (double)n->weights[0] : -1,
           n->weight_count ? (double)n->weights[1] : -1, w0, w1, line);
    const rd_mesh *m = &s->meshes[n->mesh];
    const double e[3] = {1 + w0, 1, 1 + 2 * w1};
    int found = 0;
    for (uint32_t c = 0; c < m->tri_count * 3; c++) {
        const float *rp = &m->deform->rest_positions[c * 3];
        if (rp[0] == 1 && rp[1] == 1 && rp[2] == 1) {
            found++;
            CHECKF(near3(&m->positions[c * 3], e, 1e-5), "%s corner %u: (%g %g %g) (test line %d)",
                   name, c, (double)m->positions[c * 3], (double)m->positions[c * 3 + 1],
                   (double)m->positions[c * 3 + 2], line);
        }
    }
    CHECK(found > 0);
    /* the top face's corners (triangles 2 and 3): normal (w1, 0, 1), renormalised */
    double len = sqrt(w1 * w1 + 1);
    const double nt[3] = {w1 / len, 0, 1 / len};
    for (uint32_t c = 6; c < 12; c++)
        CHECKF(near3(&m->normals[c * 3], nt, 1e-5), "%s corner %u normal (%g %g %g) (test line %d)",
               name, c, (double)m->normals[c * 3], (double)m->normals[c * 3 + 1],
               (double)m->normals[c * 3 + 2], line);
    /* and their tangents (1, w1, 0), renormalised, handedness kept */
    double tl = sqrt(1 + w1 * w1);
    const double tt[3] = {1 / tl, w1 / tl, 0};
    for (uint32_t c = 6; c < 12; c++)
        CHECKF(near3(&m->tangents[c * 4], tt, 1e-5) && m->tangents[c * 4 + 3] == 1.0f,
               "%s corner %u tangent (%g %g %g) (test line %d)", name, c,
               (double)m->tangents[c * 4], (double)m->tangents[c * 4 + 1],
               (double)m->tangents[c * 4 + 2], line);
}

static void test_morph(void)
{
    rd_scene s;
    CHECKF(load(gltf_morph_cube(), &s) == RD_GLTF_OK, "%s", err);
    CHECKF(s.warning_count == 0, "%s", s.warnings[0]);
    CHECK(s.mesh_count == 3 && s.meshes[0].deform && s.meshes[0].deform->target_count == 2);
    CHECK(s.meshes[0].deform->target_normals && s.meshes[0].deform->target_tangents);
    CHECK(s.animation_count == 1 && s.animations[0].sampler_count == 3 &&
          s.animations[0].samplers[0].components == 2);
    /* as loaded: the first mesh's default weights; "fixed" is not in the scene shown */
    check_cube(&s, "step", 0.25, 0, __LINE__);
    check_cube(&s, "linear", 0, 0, __LINE__);
    pose(&s, 0.5);
    check_cube(&s, "step", 0, 0, __LINE__);
    check_cube(&s, "linear", 0.5, 0.25, __LINE__);
    /* Hermite at u = 0.5, dt = 1: 0.5 a + 0.125 out_a + 0.5 b - 0.125 in_b = (0.625, 0.25) */
    check_cube(&s, "spline", 0.625, 0.25, __LINE__);
    pose(&s, 1.5);
    check_cube(&s, "step", 1, 0.5, __LINE__);
    check_cube(&s, "linear", 0.5, 0.75, __LINE__);
    check_cube(&s, "spline", 0.5, 0.75, __LINE__); /* zero tangents: the midpoint */
    rd_scene_destroy(&s);

    /* node weights override the mesh's: the same file with "fixed" shown, which draws the mesh
     * "step" draws: each gets a copy of its own and keeps its own pose */
    char *text = gltf_morph_cube();
    char *at = strstr(text, "\"nodes\":[0,1,2]}");
    CHECK(at != NULL);
    char *edited = test_xprintf("%.*s\"nodes\":[0,1,2,3]}%s", (int)(at - text), text,
                                at ? at + strlen("\"nodes\":[0,1,2]}") : "");
    free(text);
    CHECKF(load(edited, &s) == RD_GLTF_OK, "%s", err);
    CHECK(s.warning_count == 0 && s.mesh_count == 4);
    uint32_t step = node_named(&s, "step"), fixed = node_named(&s, "fixed");
    CHECK(s.nodes[step].mesh != s.nodes[fixed].mesh && s.meshes[s.nodes[fixed].mesh].deform);
    check_cube(&s, "fixed", 0, 0.5, __LINE__);
    check_cube(&s, "step", 0.25, 0, __LINE__);
    pose(&s, 1.5);
    check_cube(&s, "fixed", 0, 0.5, __LINE__);
    check_cube(&s, "step", 1, 0.5, __LINE__);
    rd_scene_destroy(&s);

    /* the copies count against the triangle limit: 4 meshes of 12 triangles need 48 */
    rd_gltf_options small = {.max_triangles = 40};
    text = gltf_morph_cube();
    at = strstr(text, "\"nodes\":[0,1,2]}");
    edited = test_xprintf("%.*s\"nodes\":[0,1,2,3]}%s", (int)(at - text), text,
                          at ? at + strlen("\"nodes\":[0,1,2]}") : "");
    free(text);
    CHECK(rd_gltf_load_memory(edited, strlen(edited), NULL, &small, &s, err, sizeof err) ==
          RD_GLTF_ERR_TOO_LARGE);
    CHECKF(strstr(err, "node 3 deforms mesh 0, which other nodes deform too"), "%s", err);
    CHECK(s.meshes == NULL);
    free(edited);
}

/* Every deformed vertex, normal and tangent of s is finite. */
static int deformed_finite(const rd_scene *s)
{
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        for (size_t v = 0; mesh->deform && v < (size_t)mesh->tri_count * 3; v++)
            if (!rd_vec3_isfinite(&mesh->positions[v * 3]) ||
                !rd_vec3_isfinite(&mesh->normals[v * 3]))
                return 0;
    }
    return 1;
}

/* Random edits of the arm's and the cube's JSON (the fuzz harness's check, in every ctest run):
 * any result but a crash, a sanitizer report or a non-empty scene after an error; what loads
 * must pose to finite vertices at every time. */
static void test_mutations(void)
{
    char *texts[2] = {gltf_arm(ARM_FLOAT), gltf_morph_cube()};
    uint32_t rng = 2024;
    int loaded = 0, clean = 1, finite = 1;
    for (int t = 0; t < 2; t++) {
        size_t n = strlen(texts[t]);
        const char *meshes = strstr(texts[t], "\"meshes\"");
        size_t from = meshes ? (size_t)(meshes - texts[t]) : 0; /* odd iterations: structure */
        char *m = malloc(n + 1);
        for (int iter = 0; iter < 1500; iter++) {
            test_mutate_json(m, texts[t], n, iter % 2 ? from : 0, &rng);
            rd_scene s;
            if (rd_gltf_load_memory(m, n, NULL, NULL, &s, err, sizeof err) == RD_GLTF_OK) {
                loaded++;
                for (double time = -1.0; time < 3.0; time += 0.37) {
                    rd_scene_animate(&s, time);
                    finite &= rd_scene_update(&s, err, sizeof err) && deformed_finite(&s);
                }
            } else {
                clean &= s.nodes == NULL && s.meshes == NULL && s.skins == NULL;
            }
            rd_scene_destroy(&s);
        }
        free(m);
        free(texts[t]);
    }
    CHECK(clean && finite && loaded > 0);
    fprintf(stderr, "mutations: %d of 3000 still loaded\n", loaded);
}

int main(void)
{
    test_arm();
    test_bad_skins();
    test_morph();
    test_mutations();
    return test_finish();
}
