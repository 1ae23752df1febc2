/* test_animation.c: glTF node animations, from the loader (renderer/gltf/gltf_loader.h) through
 * sampling (renderer/scene/animation_clip.c) to node world matrices, on files built here in memory
 * (JSON with a base64 buffer), plus broken files and hand-built degenerate clips. Expected
 * numbers are worked out by hand in the comments. */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/animation_clip.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/xform.h"
#include "test_util.h"

/* ---- building the file ------------------------------------------------------------------ */

/* The buffer: every region below is one buffer view and one accessor of the same index. */
static const float kTimes3[3] = {0, 1, 3};                  /* 0: SCALAR */
static const float kTrans[9] = {0, 0, 0, 2, 0, 0, 2, 4, 0}; /* 1: VEC3 LINEAR */
static const float kTimes2[2] = {0, 2};                     /* 2: SCALAR */
static const float kScale[6] = {1, 1, 1, 3, 3, 3};          /* 3: VEC3 STEP */
/* 4: VEC4 identity, then 90 degrees about +Z written as its negative (-q is the same rotation:
 * only a shortest-path slerp gets 45 degrees at the midpoint) */
static const float kRot[8] = {0, 0, 0, 1, 0, 0, -0.70710678f, -0.70710678f};
/* 5: CUBICSPLINE VEC3, per key in-tangent, value, out-tangent */
static const float kCubic[18] = {7, 7, 7, 0, 0, 0, 1, 0, 0,  /* key 0 (its in-tangent unused) */
                                 0, 2, 0, 4, 0, 0, 9, 9, 9}; /* key 1 (its out-tangent unused) */
static const float kDecreasing[3] = {0, 2, 1};               /* 6 */
static const float kNanTimes[2] = {0, NAN};                  /* 7 */
static const float kWeights[2] = {0, 1};                     /* 8: SCALAR morph weights */
static const float kNegative[2] = {-1, 0};                   /* 9 */
/* 10: VEC4 normalized i16: identity, then (0, 0, 1, 1) = 90 degrees about +Z once normalised */
static const int16_t kRotI16[8] = {0, 0, 0, 32767, 0, 0, 32767, 32767};

typedef struct region {
    const void *data;
    size_t size;
    const char *accessor; /* componentType, count and type */
} region;

static const region kRegions[] = {
    {kTimes3, sizeof kTimes3, "'componentType':5126,'count':3,'type':'SCALAR'"},
    {kTrans, sizeof kTrans, "'componentType':5126,'count':3,'type':'VEC3'"},
    {kTimes2, sizeof kTimes2, "'componentType':5126,'count':2,'type':'SCALAR'"},
    {kScale, sizeof kScale, "'componentType':5126,'count':2,'type':'VEC3'"},
    {kRot, sizeof kRot, "'componentType':5126,'count':2,'type':'VEC4'"},
    {kCubic, sizeof kCubic, "'componentType':5126,'count':6,'type':'VEC3'"},
    {kDecreasing, sizeof kDecreasing, "'componentType':5126,'count':3,'type':'SCALAR'"},
    {kNanTimes, sizeof kNanTimes, "'componentType':5126,'count':2,'type':'SCALAR'"},
    {kWeights, sizeof kWeights, "'componentType':5126,'count':2,'type':'SCALAR'"},
    {kNegative, sizeof kNegative, "'componentType':5126,'count':2,'type':'SCALAR'"},
    {kRotI16, sizeof kRotI16, "'componentType':5122,'normalized':true,'count':2,'type':'VEC4'"},
    /* 11: the same bytes, not normalized (invalid for rotation) */
    {kRotI16, sizeof kRotI16, "'componentType':5122,'count':2,'type':'VEC4'"},
};
#define REGION_COUNT (sizeof kRegions / sizeof kRegions[0])

/* glTF nodes (the loader reorders them parents first, so tests look them up by name):
 * 0 parent (animated translation) > 1 child (0,1,0) > 7 grandchild; 2 stepper (STEP scale);
 * 3 spinner (rotation); 4 spline (CUBICSPLINE translation); 5 still > 6 still child;
 * 8 framed (matrix, not in any channel of the valid file); 9 orphan (not in the scene). */
#define NODES                                                                                      \
    "'nodes':[{'name':'parent','children':[1]},"                                                   \
    "{'name':'child','translation':[0,1,0],'children':[7]},{'name':'stepper'},"                    \
    "{'name':'spinner'},{'name':'spline','translation':[5,5,5]},"                                  \
    "{'name':'still','translation':[0,0,1],'children':[6]},{'name':'still child'},"                \
    "{'name':'grandchild'},{'name':'framed','matrix':[1,0,0,0,0,1,0,0,0,0,1,0,3,0,0,1]},"          \
    "{'name':'orphan'}],'scenes':[{'nodes':[0,2,3,4,5,8]}],'scene':0"

#define MOVE_SAMPLERS                                                                              \
    "'samplers':[{'input':0,'output':1},{'input':2,'output':3,'interpolation':'STEP'},"            \
    "{'input':2,'output':4,'interpolation':'LINEAR'}]"
#define MOVE_CHANNELS                                                                              \
    "{'sampler':0,'target':{'node':0,'path':'translation'}},"                                      \
    "{'sampler':1,'target':{'node':2,'path':'scale'}},"                                            \
    "{'sampler':2,'target':{'node':3,'path':'rotation'}}"
#define SPLINE_ANIM                                                                                \
    "{'name':'spline','samplers':[{'input':2,'output':5,'interpolation':'CUBICSPLINE'}],"          \
    "'channels':[{'sampler':0,'target':{'node':4,'path':'translation'}}]}"
#define WEIGHTS_ANIM                                                                               \
    "{'samplers':[{'input':2,'output':8}],'channels':[{'sampler':0,'target':{'node':6,"            \
    "'path':'weights'}}]}"
#define VALID_ANIMATIONS                                                                           \
    "[{'name':'move'," MOVE_SAMPLERS ",'channels':[" MOVE_CHANNELS "]}," SPLINE_ANIM               \
    "," WEIGHTS_ANIM "]"

/* A glTF JSON text with the buffer above and `animations` (a JSON array, single quotes). */
static char *anim_json(const char *animations)
{
    uint8_t buf[512];
    size_t n = 0, offset[REGION_COUNT];
    for (size_t i = 0; i < REGION_COUNT; i++) {
        offset[i] = n;
        memcpy(buf + n, kRegions[i].data, kRegions[i].size);
        n += kRegions[i].size;
        while (n % 4)
            buf[n++] = 0;
    }
    char views[2048] = "", accessors[4096] = "";
    for (size_t i = 0; i < REGION_COUNT; i++) {
        size_t vl = strlen(views), al = strlen(accessors);
        snprintf(views + vl, sizeof views - vl, "%s{'buffer':0,'byteOffset':%zu,'byteLength':%zu}",
                 i ? "," : "", offset[i], kRegions[i].size);
        snprintf(accessors + al, sizeof accessors - al, "%s{'bufferView':%zu,%s}", i ? "," : "", i,
                 kRegions[i].accessor);
    }
    char *b64 = test_base64(buf, n);
    char *s = test_xprintf("{'asset':{'version':'2.0'},'buffers':[{'byteLength':%zu,'uri':"
                           "'data:application/octet-stream;base64,%s'}],'bufferViews':[%s],"
                           "'accessors':[%s]," NODES ",'animations':%s}",
                           n, b64, views, accessors, animations);
    char *j = test_jq(s);
    free(s);
    free(b64);
    return j;
}

/* ---- checking --------------------------------------------------------------------------- */

static char err[512];

static rd_gltf_result load(const char *animations, rd_scene *s)
{
    char *j = anim_json(animations);
    err[0] = '\0';
    rd_gltf_result r = rd_gltf_load_memory(j, strlen(j), NULL, NULL, s, err, sizeof err);
    free(j);
    return r;
}

static int near(float a, double b)
{
    return fabs((double)a - b) < 1e-5;
}

static int near3(const float *a, double x, double y, double z)
{
    return near(a[0], x) && near(a[1], y) && near(a[2], z);
}

static uint32_t node_named(const rd_scene *s, const char *name)
{
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].name && strcmp(s->nodes[i].name, name) == 0) return i;
    CHECKF(0, "no node '%s'", name);
    return 0;
}

static const float *world_pos(const rd_scene *s, const char *name)
{
    return &s->nodes[node_named(s, name)].world[12];
}

/* The world image of (1, 0, 0) under a node's world matrix minus its translation. */
static void world_x_axis(const rd_scene *s, const char *name, float out[3])
{
    rd_mat4_transform_dir(s->nodes[node_named(s, name)].world, (const float[3]){1, 0, 0}, out);
}

static int scene_finite(const rd_scene *s)
{
    for (uint32_t i = 0; i < s->node_count; i++) {
        const rd_node *n = &s->nodes[i];
        for (int k = 0; k < 16; k++)
            if (!isfinite(n->world[k])) return 0;
        for (int k = 0; k < 3; k++)
            if (!isfinite(n->translation[k]) || !isfinite(n->scale[k])) return 0;
        for (int k = 0; k < 4; k++)
            if (!isfinite(n->rotation[k])) return 0;
    }
    return 1;
}

static void pose(rd_scene *s, double t)
{
    rd_scene_animate(s, t);
    CHECKF(rd_scene_update(s, err, sizeof err), "%s", err);
    CHECKF(scene_finite(s), "NaN or infinity at t = %g", t);
}

/* ---- tests ------------------------------------------------------------------------------ */

static void test_load_and_sample(void)
{
    rd_scene s;
    CHECKF(load(VALID_ANIMATIONS, &s) == RD_GLTF_OK, "%s", err);
    /* the weights-only animation is dropped with a warning */
    CHECK(s.animation_count == 2);
    CHECK(s.warning_count == 1 && strstr(s.warnings[0], "weights"));
    const rd_animation *move = &s.animations[0], *spline = &s.animations[1];
    CHECK(move->name && strcmp(move->name, "move") == 0);
    CHECK(move->duration == 3.0f && move->channel_count == 3 && move->sampler_count == 3);
    CHECK(spline->duration == 2.0f && spline->channel_count == 1);
    CHECK(spline->samplers[0].interpolation == RD_INTERP_CUBICSPLINE &&
          spline->samplers[0].key_count == 2 && spline->samplers[0].components == 3);
    CHECK(spline->samplers[0].values[3] == 0.0f && spline->samplers[0].values[6] == 1.0f &&
          spline->samplers[0].values[12] == 4.0f);
    CHECK(move->samplers[1].interpolation == RD_INTERP_STEP);
    CHECK(move->samplers[2].components == 4);
    CHECK(move->channels[0].node == node_named(&s, "parent") &&
          move->channels[0].path == RD_ANIM_TRANSLATION);
    CHECK(move->channels[2].node == node_named(&s, "spinner") &&
          move->channels[2].path == RD_ANIM_ROTATION);
    CHECK(rd_scene_animation_duration(&s) == 3.0);
    /* loading leaves the static pose */
    CHECK(near3(world_pos(&s, "spline"), 5, 5, 5) && near3(world_pos(&s, "child"), 0, 1, 0));

    float x[3];
    /* t = 0.5: translation lerp (1,0,0); scale holds 1; rotation 22.5 degrees (slerp at a
     * quarter: an nlerp would give 21.6); spline at u = 0.25, dt = 2:
     * h00 .84375 h10 .140625 h01 .15625 h11 -.046875 ->
     * 2*.140625*(1,0,0) + .15625*(4,0,0) + 2*(-.046875)*(0,2,0) = (0.90625, -0.1875, 0) */
    pose(&s, 0.5);
    CHECK(near3(world_pos(&s, "parent"), 1, 0, 0));
    CHECK(near3(world_pos(&s, "child"), 1, 1, 0));
    CHECK(near3(world_pos(&s, "grandchild"), 1, 1, 0));
    CHECK(near(s.nodes[node_named(&s, "stepper")].world[0], 1));
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 0.92387953, 0.38268343, 0));
    CHECK(near3(world_pos(&s, "spline"), 0.90625, -0.1875, 0));
    CHECK(near3(world_pos(&s, "still"), 0, 0, 1));
    CHECK(near3(world_pos(&s, "framed"), 3, 0, 0));

    /* t = 1: exactly on the middle translation key; rotation midpoint 45 degrees (shortest
     * path although the key is stored as -q); spline at u = .5:
     * .5*(0) + 2*.125*(1,0,0) + .5*(4,0,0) + 2*(-.125)*(0,2,0) = (2.25, -0.5, 0) */
    pose(&s, 1.0);
    CHECK(near3(world_pos(&s, "parent"), 2, 0, 0));
    CHECK(near3(world_pos(&s, "child"), 2, 1, 0));
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 0.70710678, 0.70710678, 0));
    const float *q = s.nodes[node_named(&s, "spinner")].rotation;
    CHECK(near(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0));
    CHECK(near(fabsf(q[2]), 0.38268343) && near(fabsf(q[3]), 0.92387953));
    CHECK(near3(world_pos(&s, "spline"), 2.25, -0.5, 0));

    /* t = 1.999: the STEP key before 2 still holds */
    pose(&s, 1.999);
    CHECK(near(s.nodes[node_named(&s, "stepper")].world[0], 1));

    /* t = 2: on the STEP key (3); rotation on its last key (90 degrees); spline loops (its
     * duration is 2) to its first key, whose tangents do not matter */
    pose(&s, 2.0);
    CHECK(near(s.nodes[node_named(&s, "stepper")].world[0], 3) &&
          near(s.nodes[node_named(&s, "stepper")].world[10], 3));
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 0, 1, 0));
    CHECK(near3(world_pos(&s, "spline"), 0, 0, 0));
    CHECK(near3(world_pos(&s, "parent"), 2, 2, 0));

    /* t = 2.5: after the last rotation and scale keys (held); translation (2, 3, 0); spline
     * loop 2 at 0.5 */
    pose(&s, 2.5);
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 0, 1, 0));
    CHECK(near(s.nodes[node_named(&s, "stepper")].world[5], 3));
    CHECK(near3(world_pos(&s, "parent"), 2, 3, 0));
    CHECK(near3(world_pos(&s, "grandchild"), 2, 4, 0));
    CHECK(near3(world_pos(&s, "spline"), 0.90625, -0.1875, 0));

    /* t = 3 = the duration of "move": back to its first keys */
    pose(&s, 3.0);
    CHECK(near3(world_pos(&s, "parent"), 0, 0, 0));
    CHECK(near(s.nodes[node_named(&s, "stepper")].world[0], 1));
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 1, 0, 0));
    CHECK(near3(world_pos(&s, "spline"), 2.25, -0.5, 0)); /* 3 mod 2 = 1 */

    /* t = 4.5 (second loop, 1.5): translation (2, 1, 0); spline 4.5 mod 2 = .5 */
    pose(&s, 4.5);
    CHECK(near3(world_pos(&s, "parent"), 2, 1, 0));
    CHECK(near3(world_pos(&s, "child"), 2, 2, 0));
    CHECK(near3(world_pos(&s, "spline"), 0.90625, -0.1875, 0));
    /* a long time: 3000000.5 mod 3 = .5 and mod 2 = .5 */
    pose(&s, 3000000.5);
    CHECK(near3(world_pos(&s, "parent"), 1, 0, 0));
    CHECK(near3(world_pos(&s, "spline"), 0.90625, -0.1875, 0));
    /* negative time counts back from the end: -0.5 -> 2.5 (move), 1.5 (spline) */
    pose(&s, -0.5);
    CHECK(near3(world_pos(&s, "parent"), 2, 3, 0));
    /* -1e-20 + 3 rounds to 3 = the duration: that is the start of a loop, not its end */
    pose(&s, -1e-20);
    CHECK(near3(world_pos(&s, "parent"), 0, 0, 0));
    /* non-finite time counts as 0 */
    pose(&s, NAN);
    CHECK(near3(world_pos(&s, "parent"), 0, 0, 0));
    pose(&s, INFINITY);
    CHECK(near3(world_pos(&s, "parent"), 0, 0, 0));

    /* moving nodes: the targets and everything below them */
    bool moving[16];
    memset(moving, 0x55, sizeof moving);
    CHECK(s.node_count == 9);
    rd_scene_animated_nodes(&s, moving);
    const char *yes[] = {"parent", "child", "grandchild", "stepper", "spinner", "spline"};
    const char *no[] = {"still", "still child", "framed"};
    for (size_t i = 0; i < 6; i++)
        CHECKF(moving[node_named(&s, yes[i])] == true, "%s", yes[i]);
    for (size_t i = 0; i < 3; i++)
        CHECKF(moving[node_named(&s, no[i])] == false, "%s", no[i]);

    /* dense sweep: never NaN, rotations stay unit */
    for (int i = -50; i <= 400; i++) {
        rd_scene_animate(&s, i * 0.0137);
        CHECK(scene_finite(&s));
        const float *r = s.nodes[node_named(&s, "spinner")].rotation;
        CHECK(near(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3], 1.0));
    }
    rd_scene_destroy(&s);
    CHECK(s.animations == NULL && s.animation_count == 0);
}

static void test_normalized_rotation(void)
{
    rd_scene s;
    /* (the channel on node 9, outside the scene shown, is dropped) */
    CHECKF(load("[{'samplers':[{'input':2,'output':10}],"
                "'channels':[{'sampler':0,'target':{'node':3,'path':'rotation'}},"
                "{'sampler':0,'target':{'node':9,'path':'rotation'}}]}]",
                &s) == RD_GLTF_OK,
           "%s", err);
    CHECK(s.animation_count == 1 && s.warning_count == 0);
    CHECK(s.animations[0].channel_count == 1 && s.animations[0].sampler_count == 1);
    CHECK(s.animations[0].duration == 2.0f);
    float x[3];
    pose(&s, 1.0); /* 45 degrees */
    world_x_axis(&s, "spinner", x);
    CHECK(near3(x, 0.70710678, 0.70710678, 0));
    rd_scene_destroy(&s);
    /* a skipped weights channel still sets the loop length (its keys end at 3, not 2) */
    CHECKF(load("[{'samplers':[{'input':2,'output':3},{'input':0,'output':8}],"
                "'channels':[{'sampler':0,'target':{'node':2,'path':'scale'}},"
                "{'sampler':1,'target':{'node':6,'path':'weights'}}]}]",
                &s) == RD_GLTF_OK,
           "%s", err);
    CHECK(s.animation_count == 1 && s.warning_count == 1);
    CHECK(s.animations[0].duration == 3.0f && s.animations[0].sampler_count == 1);
    pose(&s, 2.5); /* not looped yet: the last scale key */
    CHECK(near(s.nodes[node_named(&s, "stepper")].scale[0], 3));
    rd_scene_destroy(&s);
    /* a static scene: no animation, duration 0, nothing moves, animate changes nothing */
    CHECKF(load("[]", &s) == RD_GLTF_OK, "%s", err);
    CHECK(s.animation_count == 0 && rd_scene_animation_duration(&s) == 0.0);
    bool moving[9] = {true, true, true, true, true, true, true, true, true};
    rd_scene_animated_nodes(&s, moving);
    for (int i = 0; i < 9; i++)
        CHECK(!moving[i]);
    pose(&s, 1.0);
    CHECK(near3(world_pos(&s, "spline"), 5, 5, 5));
    rd_scene_destroy(&s);
}

/* Expects RD_GLTF_ERR_INVALID with a message containing `needle`. */
static void expect_invalid(const char *animations, const char *needle, int line)
{
    rd_scene s;
    rd_gltf_result r = load(animations, &s);
    CHECKF(r == RD_GLTF_ERR_INVALID, "line %d: got %s (%s)", line, rd_gltf_strerror(r), err);
    CHECKF(strstr(err, needle) != NULL, "line %d: message '%s' lacks '%s'", line, err, needle);
    CHECKF(s.animations == NULL && s.nodes == NULL, "line %d: scene not empty", line);
    rd_scene_destroy(&s);
}
#define EXPECT_INVALID(anims, needle) expect_invalid(anims, needle, __LINE__)

#define ONE_CHANNEL(sampler, target)                                                               \
    "[{'name':'bad','samplers':[" sampler "],'channels':[{'sampler':0,'target':" target "}]}]"

static void test_invalid(void)
{
    EXPECT_INVALID(ONE_CHANNEL("{'input':6,'output':1}", "{'node':0,'path':'translation'}"),
                   "animation 0 'bad' sampler 0 has input time 1 at key 2; times must be");
    EXPECT_INVALID(ONE_CHANNEL("{'input':7,'output':3}", "{'node':0,'path':'translation'}"),
                   "has input time nan at key 1");
    EXPECT_INVALID(ONE_CHANNEL("{'input':9,'output':3}", "{'node':0,'path':'scale'}"),
                   "has input time -1 at key 0");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':1}", "{'node':0,'path':'translation'}"),
                   "animation 0 'bad' sampler 0 has 3 output values for 2 input times");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':3,'interpolation':'CUBICSPLINE'}",
                               "{'node':0,'path':'translation'}"),
                   "has 2 output values for 2 input times (CUBICSPLINE needs 6)");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':3}", "{'node':99,'path':'translation'}"),
                   "animation 0 'bad' channel 0 targets node 99, but there are only 10 nodes");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':3}", "{'node':8,'path':'translation'}"),
                   "animation 0 'bad' channel 0 animates node 8, which has a matrix");
    EXPECT_INVALID("[{'samplers':[{'input':2,'output':3}],'channels':[{'sampler':5,'target':"
                   "{'node':0,'path':'scale'}}]}]",
                   "animation 0 channel 0 refers to sampler 5, but animation 0 has only 1");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':3}", "{'node':3,'path':'rotation'}"),
                   "(output of animation 0 'bad' sampler 0) has type VEC3, expected VEC4");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':4}", "{'node':3,'path':'scale'}"),
                   "has type VEC4, expected VEC3");
    EXPECT_INVALID(ONE_CHANNEL("{'input':2,'output':11}", "{'node':3,'path':'rotation'}"),
                   "holds integers but is not normalized");
    EXPECT_INVALID(ONE_CHANNEL("{'input':3,'output':3}", "{'node':2,'path':'scale'}"),
                   "(input of animation 0 'bad' sampler 0) has type VEC3, expected SCALAR");
    EXPECT_INVALID(
        ONE_CHANNEL("{'input':2,'output':3,'interpolation':'BEZIER'}", "{'node':2,'path':'scale'}"),
        "unknown interpolation 'BEZIER'");
    /* no target at all (tinygltf itself drops a channel whose target lacks node or path) */
    EXPECT_INVALID("[{'samplers':[{'input':2,'output':3}],'channels':[{'sampler':0}]}]",
                   "animation 0 channel 0 has no target path");
    EXPECT_INVALID("[{'samplers':[{'input':2,'output':3}],'channels':[{'sampler':0,'target':"
                   "{'node':2,'path':'scale'}},{'sampler':0,'target':{'node':2,'path':'scale'}}]}]",
                   "animation 0 channel 1 animates the scale of node 2, as channel 0 does");
    EXPECT_INVALID("[" WEIGHTS_ANIM ",{'samplers':[{'input':2,'output':99}],'channels':[{'sampler'"
                   ":0,'target':{'node':2,'path':'scale'}}]}]",
                   "accessor 99");

    /* not errors: weights of a node without morph targets (warning), an unknown path (warning),
     * no node (ignored) */
    rd_scene s;
    CHECKF(load("[" WEIGHTS_ANIM ",{'samplers':[{'input':2,'output':3}],'channels':[{'sampler':0,"
                "'target':{'path':'scale'}},{'sampler':0,'target':{'node':2,'path':'pointer'}}]}]",
                &s) == RD_GLTF_OK,
           "%s", err);
    CHECK(s.animation_count == 0 && s.warning_count == 2);
    CHECK(s.warning_count == 2 &&
          strstr(s.warnings[0], "1 animation channel(s) animate the morph weights of a node") &&
          strstr(s.warnings[1], "unknown target path"));
    rd_scene_destroy(&s);
}

static rd_anim_sampler sampler(uint32_t interpolation, uint32_t components, uint32_t keys,
                               float *times, float *values)
{
    rd_anim_sampler sm = {.interpolation = interpolation,
                          .components = components,
                          .key_count = keys,
                          .times = times,
                          .values = values};
    return sm;
}

/* Clips built directly: duplicate key times, degenerate quaternions, overflowing tangents,
 * NaN keys, a single key, broken indices. */
static void test_degenerate_clips(void)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_node n;
    memset(&n, 0, sizeof n);
    n.parent = -1;
    n.mesh = -1;
    n.rotation[3] = 1;
    n.scale[0] = n.scale[1] = n.scale[2] = 1;
    for (int i = 0; i < 4; i++)
        rd_scene_add_node(&s, &n);
    n.parent = 3;
    rd_scene_add_node(&s, &n); /* node 4: child of node 3 */

    /* sampler 0: LINEAR translation with a jump at t = 1 (two keys at the same time) */
    float t0[4] = {0, 1, 1, 2};
    float v0[12] = {0, 0, 0, 1, 0, 0, 5, 0, 0, 6, 0, 0};
    /* sampler 1: LINEAR rotation between a zero quaternion and NaN */
    float t1[2] = {0, 2};
    float v1[8] = {0, 0, 0, 0, NAN, 0, 0, 1};
    /* sampler 2: CUBICSPLINE with tangents that overflow float: falls back to the key before */
    float t2[2] = {0, 100};
    float v2[18] = {0,     0,     0,     3e38f, 3e38f, 3e38f, 3e38f, 3e38f, 3e38f,
                    3e38f, 3e38f, 3e38f, 3e38f, 3e38f, 3e38f, 0,     0,     0};
    /* sampler 3: a single NaN scale key: the node keeps its scale */
    float t3[1] = {0};
    float v3[3] = {NAN, 1, 1};
    /* sampler 4: CUBICSPLINE rotation from q to -q with zero tangents: zero at u = .5, where
     * the key before (q = 90 degrees about Z) is used */
    float t5[2] = {0, 2};
    float v5[24] = {0};
    v5[6] = v5[7] = 0.70710678f;
    v5[18] = v5[19] = -0.70710678f;
    rd_anim_sampler sm[5] = {
        sampler(RD_INTERP_LINEAR, 3, 4, t0, v0),      sampler(RD_INTERP_LINEAR, 4, 2, t1, v1),
        sampler(RD_INTERP_CUBICSPLINE, 3, 2, t2, v2), sampler(RD_INTERP_STEP, 3, 1, t3, v3),
        sampler(RD_INTERP_CUBICSPLINE, 4, 2, t5, v5),
    };
    rd_anim_channel ch[7] = {
        {.node = 0, .path = RD_ANIM_TRANSLATION, .sampler = 0},
        {.node = 1, .path = RD_ANIM_ROTATION, .sampler = 1},
        {.node = 2, .path = RD_ANIM_TRANSLATION, .sampler = 2},
        {.node = 2, .path = RD_ANIM_SCALE, .sampler = 3},
        {.node = 77, .path = RD_ANIM_SCALE, .sampler = 3},   /* no such node: skipped */
        {.node = 3, .path = RD_ANIM_ROTATION, .sampler = 0}, /* 3 components: skipped */
        {.node = 0, .path = RD_ANIM_ROTATION, .sampler = 4},
    };
    rd_animation a = {.name = "odd",
                      .duration = 50,
                      .samplers = sm,
                      .sampler_count = 5,
                      .channels = ch,
                      .channel_count = 7};
    CHECK(rd_scene_add_animation(&s, &a) == 0);
    CHECK(s.animations[0].duration == 100.0f); /* the keys last longer than a.duration */
    CHECK(s.animations[0].samplers[0].times != t0 && s.animations[0].name != a.name);
    v0[3] = 99; /* the scene holds a copy */
    /* a single-key animation of duration 0 (a NaN duration reads as 0) */
    float t4[1] = {0}, v4[3] = {0, 0, 7};
    rd_anim_sampler sm4 = sampler(RD_INTERP_LINEAR, 3, 1, t4, v4);
    rd_anim_channel ch4 = {.node = 1, .path = RD_ANIM_TRANSLATION, .sampler = 0};
    rd_animation a4 = {.duration = NAN,
                       .samplers = &sm4,
                       .sampler_count = 1,
                       .channels = &ch4,
                       .channel_count = 1};
    CHECK(rd_scene_add_animation(&s, &a4) == 1);
    CHECK(s.animations[1].duration == 0.0f && s.animations[1].name == NULL);
    CHECK(rd_scene_animation_duration(&s) == 100.0);

    pose(&s, 0.5); /* halfway to the first key: (0.5, 0, 0) */
    CHECK(near3(s.nodes[0].translation, 0.5, 0, 0));
    pose(&s, 1.0); /* on the jump: the later key of equal time wins */
    CHECK(near3(s.nodes[0].translation, 5, 0, 0));
    pose(&s, 1.5);
    CHECK(near3(s.nodes[0].translation, 5.5, 0, 0));
    /* cubic rotation at u = .75: .15625 q + .84375 (-q) = -.6875 q, normalised -q */
    CHECK(near(s.nodes[0].rotation[2], -0.70710678) && near(s.nodes[0].rotation[3], -0.70710678));
    pose(&s, 1.0); /* u = .5: zero, so the key before */
    CHECK(near(s.nodes[0].rotation[2], 0.70710678) && near(s.nodes[0].rotation[3], 0.70710678));
    pose(&s, 1.5);
    /* the zero quaternion reads as identity, the NaN key as identity too: identity */
    const float *r = s.nodes[1].rotation;
    CHECK(r[0] == 0 && r[1] == 0 && r[2] == 0 && r[3] == 1);
    CHECK(near3(s.nodes[1].translation, 0, 0, 7)); /* duration 0: its only key, always */
    /* the spline overflows between its keys: the key before (3e38) is used */
    CHECK(s.nodes[2].translation[0] == 3e38f);
    CHECK(near3(s.nodes[2].scale, 1, 1, 1)); /* the NaN key changed nothing */
    CHECK(near3(s.nodes[3].scale, 1, 1, 1) && s.nodes[3].rotation[3] == 1);
    pose(&s, 50.0); /* u = .5: .5*3e38 + 12.5*3e38 + .5*3e38 - 12.5*3e38 fits again */
    CHECK(test_close_rel(s.nodes[2].translation[0], 3e38, 1e-6));

    bool moving[5];
    rd_scene_animated_nodes(&s, moving);
    /* node 3 is the target of a channel that is skipped when sampling, but it is a target */
    CHECK(moving[0] && moving[1] && moving[2] && moving[3] && moving[4]);

    /* rd_anim_sampler_eval directly: clamped ends and NaN time */
    float out[4] = {-1, -1, -1, -1};
    CHECK(rd_anim_sampler_eval(&s.animations[0].samplers[0], false, -5, out));
    CHECK(near3(out, 0, 0, 0));
    CHECK(rd_anim_sampler_eval(&s.animations[0].samplers[0], false, 50, out));
    CHECK(near3(out, 6, 0, 0));
    CHECK(rd_anim_sampler_eval(&s.animations[0].samplers[0], false, NAN, out));
    CHECK(near3(out, 0, 0, 0));
    out[0] = -1;
    CHECK(!rd_anim_sampler_eval(&s.animations[0].samplers[3], false, 0, out) && out[0] == -1);
    rd_scene_destroy(&s);
}

/* Random edits of the valid file's JSON: any result but a crash, a sanitizer report or a
 * non-empty scene after an error; what loads must sample to finite values. */
static void test_mutations(void)
{
    char *text = anim_json(VALID_ANIMATIONS);
    size_t n = strlen(text);
    const char *nodes = strstr(text, "\"nodes\"");
    size_t from = nodes ? (size_t)(nodes - text) : 0; /* odd iterations: structure only */
    uint32_t rng = 777;
    int loaded = 0, clean = 1, finite = 1;
    char *m = malloc(n + 1);
    for (int iter = 0; iter < 2000; iter++) {
        test_mutate_json(m, text, n, iter % 2 ? from : 0, &rng);
        rd_scene s;
        if (rd_gltf_load_memory(m, n, NULL, NULL, &s, err, sizeof err) == RD_GLTF_OK) {
            loaded++;
            for (double t = -1.0; t < 4.0; t += 0.37) {
                rd_scene_animate(&s, t);
                finite &= rd_scene_update(&s, err, sizeof err) && scene_finite(&s);
            }
        } else {
            clean &= s.nodes == NULL && s.animations == NULL;
        }
        rd_scene_destroy(&s);
    }
    CHECK(clean && finite && loaded > 0);
    fprintf(stderr, "mutations: %d of 2000 still loaded\n", loaded);
    free(m);
    free(text);
}

int main(void)
{
    test_load_and_sample();
    test_normalized_rotation();
    test_invalid();
    test_degenerate_clips();
    test_mutations();
    return test_finish();
}
