/* skin_builder.h: glTF test files with skins, written in memory: a buffer of regions (one buffer
 * view and one accessor each) turned into JSON with the buffer as a data URI, and the two-bone
 * arm that test_skin checks on the CPU and test_gpu_render_skin renders. Results are malloc'd (the
 * caller frees); out of memory aborts. */
#ifndef PC_TEST_SKIN_BUILDER_H
#define PC_TEST_SKIN_BUILDER_H

#include <stddef.h>
#include <stdint.h>

/* A buffer of regions: accessor i reads buffer view i, which holds region i. */
typedef struct gltf_file {
    uint8_t data[4096];
    size_t n;
    char views[4096], accessors[4096];
    int count;
} gltf_file;

/* Appends size bytes (4-byte aligned) read by an accessor described by acc (its componentType,
 * count, type ... in single quotes); returns the accessor's index. */
int gltf_file_add(gltf_file *f, const void *p, size_t size, const char *acc);
/* The glTF JSON text (double quotes) of f with the top-level members rest (single quotes). */
char *gltf_file_json(const gltf_file *f, const char *rest);

/* The arm: six vertices along +X at x = 0, 1, 2 (y = -0.1, 0.1), facing +Z with tangent +X; the
 * first two follow the shoulder (joint 0, node "shoulder" at the origin), the last two the elbow
 * (joint 1, node "elbow" at x = 1), the middle two both, half each. The elbow turns about +Z from
 * 0 to 90 degrees over the first second (LINEAR) and stays there until 2 s; the arm's mesh node
 * ("arm") sits at z = 5, which the skin ignores (glTF 2.0 section 3.7.3.3). */
extern const float kArmPos[18];
extern const uint16_t kArmIdx[12]; /* two quads, four triangles */

enum {
    ARM_FLOAT = 0,        /* JOINTS_0 unsigned bytes, WEIGHTS_0 floats */
    ARM_NORMALIZED = 1,   /* unsigned shorts, normalized unsigned bytes (128/255 + 127/255) */
    ARM_HALF_WEIGHTS = 2, /* float weights summing to 0.5 */
    ARM_BAD_JOINT = 3,    /* the tip bound to joint 5 of a two-joint skin */
    ARM_TWO_SETS = 4      /* as ARM_FLOAT, the middle's elbow half in JOINTS_1 / WEIGHTS_1 */
};
char *gltf_arm(int kind);
/* gltf_arm(ARM_FLOAT) with a camera (node "cam", yfov 0.7) 4 m in front of the arm's middle at
 * (1, 0.4, 4), looking down -Z. */
char *gltf_arm_with_camera(void);

/* The cube [-1, 1]^3 (8 vertices, 12 triangles) with two morph targets: 0 moves every vertex by
 * +1 in x, 1 moves the top (z = 1) by +2 in z, adds (1, 0, 0) to its vertices' normals (the
 * flat normals of triangles 2 and 3, the top face: (0, 0, 1)) and (0, 1, 0) to their tangents
 * (all (1, 0, 0, 1); the delta a sparse accessor). Three nodes ("step",
 * "linear", "spline") draw a mesh of it each, their weights animated over keys at 0, 1, 2 s by
 * STEP, LINEAR and CUBICSPLINE samplers: (0, 0), (1, 0.5), (0, 1); the spline's out-tangent of
 * key 0 is (1, 0), its other tangents 0. The first mesh's default weights are (0.25, 0); a fourth
 * node ("fixed", not in the scene) draws it with weights (0, 0.5). */
char *gltf_morph_cube(void);

#endif
