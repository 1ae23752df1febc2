/* test_scene.c: the CPU scene model (renderer/scene/scene.c) and its matrix helpers (xform.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/scene.h"
#include "renderer/scene/xform.h"
#include "test_util.h"

static int near3(const float *a, float x, float y, float z)
{
    return fabsf(a[0] - x) < 1e-5f && fabsf(a[1] - y) < 1e-5f && fabsf(a[2] - z) < 1e-5f;
}

static rd_node make_node(int32_t parent, int32_t mesh)
{
    rd_node n;
    memset(&n, 0, sizeof n);
    n.parent = parent;
    n.mesh = mesh;
    n.rotation[3] = 1.0f;
    n.scale[0] = n.scale[1] = n.scale[2] = 1.0f;
    return n;
}

/* One triangle (0,0,0) (1,0,0) (0,1,0) with zero normals. */
static uint32_t add_triangle(rd_scene *s)
{
    uint32_t m = rd_scene_add_mesh(s, "tri", 1);
    static const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(s->meshes[m].positions, p, sizeof p);
    return m;
}

static void test_init_destroy(void)
{
    rd_scene s;
    rd_scene_init(&s);
    CHECK(s.material_count == 1);
    CHECK(s.materials[0].name && strcmp(s.materials[0].name, "default") == 0);
    CHECK(s.materials[0].base_color[0] == 1.0f && s.materials[0].base_color[3] == 1.0f);
    CHECK(s.materials[0].emission[0] == 0.0f);
    CHECK(s.materials[0].base_color_texture == -1 && s.materials[0].emissive_texture == -1);
    CHECK(s.materials[0].alpha_mode == RD_ALPHA_OPAQUE);
    CHECK(s.materials[0].alpha_cutoff == 0.5f);
    CHECK(!s.materials[0].double_sided);

    rd_scene_warn(&s, "warning %d %s", 7, "x");
    CHECK(s.warning_count == 1 && strcmp(s.warnings[0], "warning 7 x") == 0);
    uint8_t *px = malloc(16);
    memset(px, 0x7f, 16);
    rd_texture t = {.width = 2, .height = 2, .rgba = px};
    CHECK(rd_scene_add_texture(&s, &t) == 0);
    rd_light l = {.name = "sun", .node = -1};
    CHECK(rd_scene_add_light(&s, &l) == 0);
    CHECK(s.lights[0].name != l.name && strcmp(s.lights[0].name, "sun") == 0);
    rd_camera c = {.name = "cam", .node = -1, .yfov = 1.0f};
    CHECK(rd_scene_add_camera(&s, &c) == 0);
    add_triangle(&s);
    CHECK(s.meshes[0].tri_count == 1 && s.meshes[0].material[0] == 0);
    char err[128];
    CHECK(rd_scene_update(&s, err, sizeof err));
    /* no instances: unit box at the origin */
    CHECK(near3(s.bounds_min, -0.5f, -0.5f, -0.5f) && near3(s.bounds_max, 0.5f, 0.5f, 0.5f));

    rd_scene_destroy(&s);
    rd_scene zero;
    memset(&zero, 0, sizeof zero);
    CHECK(memcmp(&s, &zero, sizeof s) == 0);
    rd_scene_destroy(&s); /* idempotent */
    CHECK(memcmp(&s, &zero, sizeof s) == 0);
}

static void test_xform(void)
{
    float m[16], inv[16], id[16], p[3];
    const float t[3] = {1, 2, 3}, q[4] = {0, 0, 0.70710678f, 0.70710678f}, sc[3] = {2, 3, 4};
    rd_mat4_from_trs(m, t, q, sc);
    /* (1,0,0) scaled to (2,0,0), rotated 90 degrees about Z to (0,2,0), translated */
    rd_mat4_transform_point(m, (float[3]){1, 0, 0}, p);
    CHECK(near3(p, 1, 4, 3));
    rd_mat4_transform_dir(m, (float[3]){0, 1, 0}, p);
    CHECK(near3(p, -3, 0, 0));
    CHECK(rd_mat4_inverse(inv, m));
    rd_mat4_mul(id, inv, m);
    float ident[16];
    rd_mat4_identity(ident);
    int ok = 1;
    for (int i = 0; i < 16; i++)
        ok &= fabsf(id[i] - ident[i]) < 1e-5f;
    CHECK(ok);
    CHECK(fabsf(rd_mat4_det3(m) - 24.0f) < 1e-4f);
    float mirror[16];
    rd_mat4_from_trs(mirror, t, (float[4]){0, 0, 0, 1}, (float[3]){-1, 1, 1});
    CHECK(rd_mat4_det3(mirror) < 0.0f);
    /* normals under non-uniform scale: the plane x + y = 1 scaled by (2,1,1) has normal (1,2,0) */
    float s2[16], n[3];
    rd_mat4_from_trs(s2, (float[3]){0, 0, 0}, (float[4]){0, 0, 0, 1}, (float[3]){2, 1, 1});
    rd_mat4_transform_normal(s2, (float[3]){1, 1, 0}, n);
    rd_vec3_normalize(n, n, NULL);
    CHECK(near3(n, 1.0f / sqrtf(5.0f), 2.0f / sqrtf(5.0f), 0));
    /* a mirror flips the normal with the geometry */
    rd_mat4_transform_normal(mirror, (float[3]){1, 0, 0}, n);
    CHECK(near3(n, -1, 0, 0));
    float sing[16] = {0};
    CHECK(!rd_mat4_inverse(inv, sing));
    /* a zero quaternion means no rotation */
    rd_mat4_from_trs(m, (float[3]){0, 0, 0}, (float[4]){0, 0, 0, 0}, (float[3]){1, 1, 1});
    CHECK(m[0] == 1.0f && m[5] == 1.0f && m[10] == 1.0f);
    float v[3];
    CHECK(!rd_vec3_normalize(v, (float[3]){0, 0, 0}, (float[3]){0, 0, 1}) && near3(v, 0, 0, 1));
    CHECK(fabsf(rd_vec3_dot((float[3]){1, 2, 3}, (float[3]){4, 5, 6}) - 32.0f) < 1e-6f);
}

static void test_hierarchy(void)
{
    rd_scene s;
    rd_scene_init(&s);
    uint32_t mesh = add_triangle(&s);
    /* children stored before their parents on purpose */
    rd_node grandchild = make_node(2, (int32_t)mesh);
    grandchild.scale[0] = grandchild.scale[1] = grandchild.scale[2] = 2.0f;
    rd_node child = make_node(2, -1);
    child.translation[0] = 1.0f;
    child.rotation[2] = 0.70710678f; /* 90 degrees about Z */
    child.rotation[3] = 0.70710678f;
    rd_node root = make_node(-1, -1);
    root.has_matrix = true;
    rd_mat4_identity(root.matrix);
    root.matrix[12] = 10.0f; /* translation (10, 0, 5) */
    root.matrix[14] = 5.0f;
    grandchild.parent = 1;
    rd_scene_add_node(&s, &grandchild); /* 0 */
    rd_scene_add_node(&s, &child);      /* 1 */
    rd_scene_add_node(&s, &root);       /* 2 */

    rd_light sun = {.type = RD_LIGHT_DIRECTIONAL, .node = 1, .intensity = 1.0f};
    rd_scene_add_light(&s, &sun);
    rd_camera cam = {.yfov = 1.0f, .node = 1};
    rd_scene_add_camera(&s, &cam);
    rd_light free_light = {.type = RD_LIGHT_POINT, .node = -1, .position = {7, 8, 9}};
    rd_scene_add_light(&s, &free_light);

    char err[128];
    CHECK(rd_scene_update(&s, err, sizeof err));
    float p[3];
    /* grandchild: scale 2, then child's rotation, then translations (1,0,0) and (10,0,5) */
    rd_mat4_transform_point(s.nodes[0].world, (float[3]){1, 0, 0}, p);
    CHECK(near3(p, 11, 2, 5));
    rd_mat4_transform_point(s.nodes[0].world, (float[3]){0, 1, 0}, p);
    CHECK(near3(p, 9, 0, 5));
    CHECK(near3(&s.nodes[1].world[12], 11, 0, 5));
    CHECK(s.instance_count == 1 && s.instances[0].node == 0 && s.instances[0].mesh == mesh);
    CHECK(s.tri_total == 1);
    CHECK(near3(s.bounds_min, 9, 0, 5) && near3(s.bounds_max, 11, 2, 5));
    /* the light and camera follow node 1: -Z and +Y stay (0,0,-1), rotated +Y is -X */
    CHECK(near3(s.lights[0].position, 11, 0, 5));
    CHECK(near3(s.lights[0].direction, 0, 0, -1));
    CHECK(near3(s.cameras[0].forward, 0, 0, -1));
    CHECK(near3(s.cameras[0].up, -1, 0, 0));
    CHECK(near3(s.cameras[0].position, 11, 0, 5));
    CHECK(near3(s.lights[1].position, 7, 8, 9)); /* unplaced: untouched */

    /* a second instance widens the bounds and the triangle total */
    rd_node other = make_node(-1, (int32_t)mesh);
    other.translation[2] = -3.0f;
    rd_scene_add_node(&s, &other);
    CHECK(rd_scene_update(&s, err, sizeof err));
    CHECK(s.instance_count == 2 && s.tri_total == 2);
    CHECK(near3(s.bounds_min, 0, 0, -3) && near3(s.bounds_max, 11, 2, 5));
    rd_scene_destroy(&s);
}

static void test_broken_hierarchy(void)
{
    rd_scene s;
    char err[160];
    rd_scene_init(&s);
    rd_node a = make_node(1, -1), b = make_node(2, -1), c = make_node(0, -1);
    rd_scene_add_node(&s, &a);
    rd_scene_add_node(&s, &b);
    rd_scene_add_node(&s, &c);
    CHECK(!rd_scene_update(&s, err, sizeof err));
    CHECKF(strstr(err, "cycle") != NULL, "%s", err);
    s.nodes[2].parent = 2;
    CHECK(!rd_scene_update(&s, err, sizeof err));
    CHECKF(strstr(err, "own parent") != NULL, "%s", err);
    s.nodes[2].parent = 7;
    CHECK(!rd_scene_update(&s, err, sizeof err));
    CHECKF(strstr(err, "parent 7") != NULL, "%s", err);
    s.nodes[2].parent = -1;
    CHECK(rd_scene_update(&s, err, sizeof err));
    s.nodes[2].mesh = 3;
    CHECK(!rd_scene_update(&s, err, sizeof err));
    CHECKF(strstr(err, "mesh 3") != NULL, "%s", err);
    s.nodes[2].mesh = -1;
    rd_light l = {.node = 5};
    rd_scene_add_light(&s, &l);
    CHECK(!rd_scene_update(&s, err, sizeof err));
    CHECKF(strstr(err, "light 0") != NULL, "%s", err);
    rd_scene_destroy(&s);

    /* a long chain is handled without recursion */
    rd_scene_init(&s);
    for (int i = 0; i < 100000; i++) {
        rd_node n = make_node(i - 1, -1);
        n.translation[0] = 1.0f;
        rd_scene_add_node(&s, &n);
    }
    CHECK(rd_scene_update(&s, err, sizeof err));
    CHECK(fabsf(s.nodes[99999].world[12] - 100000.0f) < 1.0f);
    rd_scene_destroy(&s);
}

static void test_bounds_and_normals(void)
{
    rd_scene s;
    char err[128];
    rd_scene_init(&s);
    uint32_t m = rd_scene_add_mesh(&s, NULL, 3);
    rd_mesh *mesh = &s.meshes[m];
    CHECK(mesh->name == NULL);
    static const float p[27] = {
        0, 0, 0, 1, 0, 0, 0,   1, 0, /* CCW seen from +Z */
        0, 0, 0, 0, 1, 0, 1,   0, 0, /* CW: normal -Z */
        2, 2, 2, 2, 2, 2, NAN, 5, 5, /* degenerate, with a NaN vertex */
    };
    memcpy(mesh->positions, p, sizeof p);
    mesh->normals[3] = 1.0f; /* triangle 0 vertex 1 has its own normal (1,0,0) */
    mesh->normals[7] = NAN;  /* triangle 0 vertex 2: NaN counts as missing */
    rd_mesh_fill_flat_normals(mesh);
    CHECK(near3(&mesh->normals[0], 0, 0, 1));
    CHECK(near3(&mesh->normals[3], 1, 0, 0));
    CHECK(near3(&mesh->normals[6], 0, 0, 1));
    CHECK(near3(&mesh->normals[9], 0, 0, -1) && near3(&mesh->normals[15], 0, 0, -1));
    CHECK(near3(&mesh->normals[18], 0, 0, 1) && near3(&mesh->normals[24], 0, 0, 1));

    rd_node n = make_node(-1, (int32_t)m);
    rd_scene_add_node(&s, &n);
    CHECK(rd_scene_update(&s, err, sizeof err));
    CHECK(near3(s.bounds_min, 0, 0, 0) && near3(s.bounds_max, 2, 2, 2)); /* NaN skipped */
    CHECK(s.tri_total == 3);

    /* only non-finite vertices: unit box */
    for (int i = 0; i < 27; i++)
        mesh->positions[i] = INFINITY;
    CHECK(rd_scene_update(&s, err, sizeof err));
    CHECK(near3(s.bounds_min, -0.5f, -0.5f, -0.5f) && near3(s.bounds_max, 0.5f, 0.5f, 0.5f));
    rd_scene_destroy(&s);
}

/* Arrays grow geometrically; lowering a count directly and adding again stays in bounds. */
static void test_growth(void)
{
    rd_scene s;
    rd_scene_init(&s);
    for (int i = 0; i < 20; i++) {
        rd_node n = make_node(-1, -1);
        n.translation[0] = (float)i;
        CHECK(rd_scene_add_node(&s, &n) == (uint32_t)i);
    }
    s.node_count = 3;
    for (int i = 0; i < 30; i++) {
        rd_node n = make_node(-1, -1);
        n.translation[0] = 100.0f + (float)i;
        rd_scene_add_node(&s, &n);
    }
    CHECK(s.node_count == 33);
    CHECK(s.nodes[2].translation[0] == 2.0f && s.nodes[32].translation[0] == 129.0f);
    rd_scene_destroy(&s);
}

/* Removing a light frees its name, keeps the others in order and ignores bad indices. */
static void test_remove_light(void)
{
    rd_scene s;
    rd_scene_init(&s);
    const char *names[3] = {"a", "b", "c"};
    for (int i = 0; i < 3; i++) {
        rd_light l = {.name = (char *)names[i], .type = RD_LIGHT_POINT, .intensity = (float)i};
        rd_scene_add_light(&s, &l);
    }
    rd_scene_remove_light(&s, 1);
    CHECK(s.light_count == 2);
    CHECK(strcmp(s.lights[0].name, "a") == 0 && strcmp(s.lights[1].name, "c") == 0);
    CHECK(s.lights[1].intensity == 2.0f);
    rd_scene_remove_light(&s, 7); /* out of range: nothing happens */
    CHECK(s.light_count == 2);
    rd_scene_remove_light(&s, 1);
    rd_scene_remove_light(&s, 0);
    CHECK(s.light_count == 0);
    rd_light l = {.name = "d"};
    CHECK(rd_scene_add_light(&s, &l) == 0); /* the array is still usable */
    rd_scene_destroy(&s);
}

int main(void)
{
    test_remove_light();
    test_growth();
    test_init_destroy();
    test_xform();
    test_hierarchy();
    test_broken_hierarchy();
    test_bounds_and_normals();
    return test_finish();
}
