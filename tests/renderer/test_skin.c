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

/* ---- the morphing cube -------------------------------------------------------------------- */

/* The cube [-1, 1]^3 (8 vertices, 12 triangles) with two targets: 0 moves every vertex by +1 in
 * x, 1 moves the top (z = 1) by +2 in z and tilts its normals. Three nodes draw a mesh of it
 * each, their weights animated over keys at 0, 1, 2 s by STEP, LINEAR and CUBICSPLINE samplers:
 * (0, 0), (1, 0.5), (0, 1); the spline's out-tangent of key 0 is (1, 0), its other tangents 0.
 * The first mesh's default weights are (0.25, 0), a fourth node shows it with weights (0, 0.5). */
static char *cube_json(void)
{
    gltf_file f;
    memset(&f, 0, sizeof f);
    float pos[24], d0[24], d1[24], n1[24];
    for (int v = 0; v < 8; v++) {
        pos[v * 3] = v & 1 ? 1 : -1, pos[v * 3 + 1] = v & 2 ? 1 : -1,
                pos[v * 3 + 2] = v & 4 ? 1 : -1;
        d0[v * 3] = 1, d0[v * 3 + 1] = 0, d0[v * 3 + 2] = 0;
        d1[v * 3] = 0, d1[v * 3 + 1] = 0, d1[v * 3 + 2] = v & 4 ? 2 : 0;
        n1[v * 3] = 0, n1[v * 3 + 1] = 0, n1[v * 3 + 2] = 0;
    }
    static const uint16_t idx[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    gltf_file_add(
        &f, pos, sizeof pos,
        "'componentType':5126,'count':8,'type':'VEC3','min':[-1,-1,-1],'max':[1,1,1]");    /* 0 */
    gltf_file_add(&f, idx, sizeof idx, "'componentType':5123,'count':36,'type':'SCALAR'"); /* 1 */
    gltf_file_add(&f, d0, sizeof d0, "'componentType':5126,'count':8,'type':'VEC3'");      /* 2 */
    gltf_file_add(&f, d1, sizeof d1, "'componentType':5126,'count':8,'type':'VEC3'");      /* 3 */
    gltf_file_add(&f, n1, sizeof n1, "'componentType':5126,'count':8,'type':'VEC3'");      /* 4 */
    const float times[3] = {0, 1, 2};
    gltf_file_add(&f, times, sizeof times,
                  "'componentType':5126,'count':3,'type':'SCALAR','min':[0],'max':[2]"); /* 5 */
    const float w[6] = {0, 0, 1, 0.5f, 0, 1};
    gltf_file_add(&f, w, sizeof w, "'componentType':5126,'count':6,'type':'SCALAR'"); /* 6 */
    const float cubic[18] = {0, 0, 0, 0,    1, 0,  /* key 0: in, value, out */
                             0, 0, 1, 0.5f, 0, 0,  /* key 1 */
                             0, 0, 0, 1,    0, 0}; /* key 2 */
    gltf_file_add(&f, cubic, sizeof cubic,
                  "'componentType':5126,'count':18,'type':'SCALAR'"); /* 7 */
#define CUBE_PRIM                                                                                  \
    "{'primitives':[{'attributes':{'POSITION':0},'indices':1,'targets':[{'POSITION':2},"           \
    "{'POSITION':3,'NORMAL':4}]}]"
    return gltf_file_json(
        &f, "'meshes':[" CUBE_PRIM ",'weights':[0.25,0]}," CUBE_PRIM "}," CUBE_PRIM "}],"
            "'nodes':[{'name':'step','mesh':0},{'name':'linear','mesh':1},"
            "{'name':'spline','mesh':2},{'name':'fixed','mesh':0,'weights':[0,0.5]}],"
            "'scenes':[{'nodes':[0,1,2]}],"
            "'animations':[{'samplers':[{'input':5,'output':6,'interpolation':'STEP'},"
            "{'input':5,'output':6},{'input':5,'output':7,'interpolation':'CUBICSPLINE'}],"
            "'channels':[{'sampler':0,'target':{'node':0,'path':'weights'}},"
            "{'sampler':1,'target':{'node':1,'path':'weights'}},"
            "{'sampler':2,'target':{'node':2,'path':'weights'}}]}]");
}

/* Node `name`'s weights are (w0, w1), and its mesh's top corner (glTF vertex 7 = (1, 1, 1))
 * moved to (1 + w0, 1, 1 + 2 w1). */
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
}

static void test_morph(void)
{
    rd_scene s;
    CHECKF(load(cube_json(), &s) == RD_GLTF_OK, "%s", err);
    CHECKF(s.warning_count == 0, "%s", s.warnings[0]);
    CHECK(s.mesh_count == 3 && s.meshes[0].deform && s.meshes[0].deform->target_count == 2);
    CHECK(s.meshes[0].deform->target_normals && !s.meshes[0].deform->target_tangents);
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

    /* node weights override the mesh's: the same file with "fixed" shown */
    char *text = cube_json();
    char *at = strstr(text, "\"nodes\":[0,1,2]");
    CHECK(at != NULL);
    if (at) memcpy(at, "\"nodes\":[3,1,2]", 15);
    CHECKF(load(text, &s) == RD_GLTF_OK, "%s", err);
    check_cube(&s, "fixed", 0, 0.5, __LINE__);
    rd_scene_destroy(&s);
}

int main(void)
{
    test_arm();
    test_bad_skins();
    test_morph();
    return test_finish();
}
