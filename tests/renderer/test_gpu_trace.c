/* test_gpu_trace.c: shaders/trace.glsl on the device against a CPU brute force in world space.
 *
 * Two meshes (a random soup and a subdivided cube) are placed by four instances: rotated and
 * non-uniformly scaled, mirrored (negative determinant), rotated and scaled uniformly,
 * turned by a two-axis negative scale (positive determinant), and only translated (exactly).
 * Rays with zero direction components run exactly along the last one's edges and through its
 * vertices: there the GPU must agree with the CPU exactly (watertight, and the slab test's
 * 0 * inf cases); elsewhere hits within EDGE_EPS of an edge may go either way. Their BLASes share
 * one node and one triangle array with absolute indices, as the renderer uploads them. Two TLASes
 * are traced: one built by rd_bvh_build (one instance per leaf) and a single leaf holding all four
 * instances. Each is traced with closest hit, any hit, back-face culling and both. Runs with
 * PROBECAST_VALIDATION=1 PROBECAST_DEVICE=llvmpipe under ctest. */
#include "renderer/accel/bvh.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/vk/vk_context.h"
#include "shaders/gpu_types.h"
#include "shaders/test_trace.spv.h"
#include "test_render_util.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MESHES 2
#define INSTANCES 5
#define RAYS 1024
#define ALPHA_CUT 0.3f /* test_trace.comp keeps u > 0.3 on alpha-masked triangles */
#define EDGE_EPS 1e-4f /* hits closer than this to an edge or the cut may go either way */

static char err[512];

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;

static float rng_f(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (float)(rng_state >> 40) * (1.0f / 16777216.0f);
}

static float rng_range(float a, float b)
{
    return a + (b - a) * rng_f();
}

typedef struct mesh {
    uint32_t n;
    float *pos;      /* 9 floats per triangle, object space, original order */
    uint32_t *flags; /* PC_TRI_* per triangle */
    rd_bvh bvh;
    uint32_t node_base, tri_base;
} mesh;

typedef struct instance {
    uint32_t mesh;
    double m[3][4]; /* object to world rows */
    double inv[3][4];
    bool neg_det;
    bool exact;   /* a translation by dyadic numbers: object and world arithmetic agree */
    float *world; /* the mesh's triangles in world space */
} instance;

/* ---- scene ------------------------------------------------------------------------------- */

static void make_soup(mesh *m, uint32_t n)
{
    m->n = n;
    m->pos = malloc(n * 9 * sizeof(float));
    m->flags = malloc(n * sizeof(uint32_t));
    for (uint32_t i = 0; i < n; i++) {
        float c[3] = {rng_range(-1, 1), rng_range(-1, 1), rng_range(-1, 1)};
        for (int k = 0; k < 9; k++)
            m->pos[9 * i + k] = c[k % 3] + rng_range(-0.3f, 0.3f);
        m->flags[i] =
            (i % 3 == 0 ? PC_TRI_DOUBLE_SIDED : 0u) | (i % 5 == 0 ? PC_TRI_ALPHA_MASK : 0u);
    }
}

/* Cube [-1,1]^3, each face 2 x 2 cells of two triangles, counter-clockwise seen from outside. */
static void make_cube(mesh *m)
{
    const int g = 2;
    m->n = 6 * g * g * 2;
    m->pos = malloc(m->n * 9 * sizeof(float));
    m->flags = calloc(m->n, sizeof(uint32_t));
    test_make_cube(m->pos, g);
    m->flags[3] = PC_TRI_ALPHA_MASK;
}

/* rows = T * R(axis, angle) * S */
static void make_transform(instance *in, const double axis[3], double angle, const double s[3],
                           const double t[3])
{
    double l = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double x = axis[0] / l, y = axis[1] / l, z = axis[2] / l, c = cos(angle), sn = sin(angle),
           C = 1 - c;
    double r[3][3] = {{c + x * x * C, x * y * C - z * sn, x * z * C + y * sn},
                      {y * x * C + z * sn, c + y * y * C, y * z * C - x * sn},
                      {z * x * C - y * sn, z * y * C + x * sn, c + z * z * C}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            in->m[i][j] = r[i][j] * s[j];
        in->m[i][3] = t[i];
    }
    double(*a)[4] = in->m;
    double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                 a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                 a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    in->neg_det = det < 0;
    double inv[3][3] = {{(a[1][1] * a[2][2] - a[1][2] * a[2][1]) / det,
                         (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det,
                         (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det},
                        {(a[1][2] * a[2][0] - a[1][0] * a[2][2]) / det,
                         (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det,
                         (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det},
                        {(a[1][0] * a[2][1] - a[1][1] * a[2][0]) / det,
                         (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det,
                         (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det}};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            in->inv[i][j] = inv[i][j];
        in->inv[i][3] = -(inv[i][0] * t[0] + inv[i][1] * t[1] + inv[i][2] * t[2]);
    }
}

static void xform(const double m[3][4], const float p[3], float out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = (float)(m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3]);
}

/* ---- CPU reference ------------------------------------------------------------------------- */

typedef struct cpu_hit {
    bool hit;
    float t, u, v;
    uint32_t instance, tri; /* tri: the mesh's own index */
    bool backface;
} cpu_hit;

/* Whether a candidate hit passes culling and the alpha cut-out (as trace.glsl decides). */
static bool accepted(uint32_t tri_flags, bool back, float u, uint32_t flags)
{
    if ((flags & PC_TRACE_CULL_BACKFACES) && back && !(tri_flags & PC_TRI_DOUBLE_SIDED))
        return false;
    if ((tri_flags & PC_TRI_ALPHA_MASK) && !(u > ALPHA_CUT)) return false;
    return true;
}

/* Closest accepted hit over every world-space triangle. */
static cpu_hit cpu_trace(const mesh *meshes, const instance *inst, const float o[3],
                         const float d[3], float tmin, float tmax, uint32_t flags)
{
    cpu_hit best = {.hit = false, .t = tmax};
    for (uint32_t k = 0; k < INSTANCES; k++) {
        const mesh *m = &meshes[inst[k].mesh];
        for (uint32_t i = 0; i < m->n; i++) {
            const float *w = inst[k].world + 9 * i;
            float t, u, v;
            bool back;
            if (!rd_ray_triangle(o, d, w, w + 3, w + 6, tmin, best.t, &t, &u, &v, &back)) continue;
            back = back != inst[k].neg_det; /* glTF: a mirroring node keeps the object's front */
            if (!accepted(m->flags[i], back, u, flags)) continue;
            best = (cpu_hit){true, t, u, v, k, i, back};
        }
    }
    return best;
}

/* A hit whose barycentrics lie within EDGE_EPS of an edge or of the alpha cut. */
static bool ambiguous_uv(float u, float v)
{
    return u < EDGE_EPS || v < EDGE_EPS || 1.0f - u - v < EDGE_EPS ||
           fabsf(u - ALPHA_CUT) < EDGE_EPS;
}

/* ---- test -------------------------------------------------------------------------------- */

typedef struct gpu_hit {
    uint32_t t, u, v, hit;
    uint32_t instance, tri, backface, pad;
} gpu_hit;

static void make_rays(float *rays, const instance *inst, const mesh *meshes)
{
    for (uint32_t r = 0; r < RAYS; r++) {
        float *a = rays + 8 * r, *b = a + 4;
        for (int k = 0; k < 3; k++)
            a[k] = rng_range(-7, 7);
        float tgt[3];
        if (r % 8 < 6) { /* aimed at a random point of a random world triangle */
            const instance *in = &inst[r % INSTANCES];
            const float *w =
                in->world + 9 * ((uint32_t)(rng_f() * meshes[in->mesh].n) % meshes[in->mesh].n);
            float w1 = rng_f(), w2 = rng_f() * (1 - w1), w0 = 1 - w1 - w2;
            for (int k = 0; k < 3; k++)
                tgt[k] = w0 * w[k] + w1 * w[3 + k] + w2 * w[6 + k];
        } else {
            for (int k = 0; k < 3; k++)
                tgt[k] = rng_range(-5, 5);
        }
        for (int k = 0; k < 3; k++)
            b[k] = tgt[k] - a[k];
        if (r % 8 == 7) {
            /* along the exact cube's grid lines: zero direction components, origins on the
             * BVH's box planes, hits on edges and vertices */
            const float grid[5] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
            int axis = (int)(r / 8) % 3;
            float sign = (r / 24) % 2 ? 1.0f : -1.0f;
            for (int k = 0; k < 3; k++) {
                a[k] = inst[4].m[k][3] + grid[(uint32_t)(rng_f() * 5) % 5];
                b[k] = 0.0f;
            }
            a[axis] = (float)inst[4].m[axis][3] - 10.0f * sign;
            b[axis] = sign * ((r / 48) % 2 ? 1.0f : 0.25f);
            if (r % 64 == 15) /* diagonal through vertices */
                b[(axis + 1) % 3] = b[axis];
        }
        a[3] = (r % 3 == 0) ? 0.0f : 1e-3f;
        b[3] = (r % 4 == 0) ? INFINITY : 100.0f;
        if (r % 64 == 1)
            b[3] = 0.5f * sqrtf(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]) / 14.0f; /* short */
    }
}

/* Compares one dispatch's results with the CPU. Returns the number of ambiguous rays. */
static uint32_t compare(const char *what, const float *rays, const gpu_hit *g, const mesh *meshes,
                        const instance *inst, const pc_tri *tris, uint32_t tri_total,
                        uint32_t flags)
{
    uint32_t bad = 0, ambiguous = 0, hits = 0;
    for (uint32_t r = 0; r < RAYS; r++) {
        const float *a = rays + 8 * r, *b = a + 4;
        cpu_hit c = cpu_trace(meshes, inst, a, b, a[3], b[3], flags);
        bool gh = g[r].hit != 0;
        float gt = pc_u2f(g[r].t), gu = pc_u2f(g[r].u), gv = pc_u2f(g[r].v);
        uint32_t gtri = PC_INVALID;
        bool valid_index = true;
        if (gh) {
            valid_index = g[r].instance < INSTANCES && g[r].tri < tri_total;
            if (valid_index) {
                const mesh *m = &meshes[inst[g[r].instance].mesh];
                valid_index = g[r].tri >= m->tri_base && g[r].tri < m->tri_base + m->n;
                gtri = pc_f2u(tris[g[r].tri].v2.w);
                valid_index = valid_index && gtri < m->n;
            }
        }
        hits += c.hit;
        const char *problem = NULL;
        bool amb = (c.hit && !inst[c.instance].exact && ambiguous_uv(c.u, c.v)) ||
                   (gh && valid_index && !inst[g[r].instance].exact && ambiguous_uv(gu, gv));
        if (!valid_index) {
            problem = "bad instance/triangle index";
            amb = false;
        } else if (gh != c.hit) {
            problem = gh ? "GPU hit, CPU miss" : "GPU miss, CPU hit";
        } else if (gh && (flags & PC_TRACE_ANY_HIT)) {
            /* any hit: the GPU's hit must itself be an accepted hit of the CPU ray */
            const float *w = inst[g[r].instance].world + 9 * gtri;
            const mesh *m = &meshes[inst[g[r].instance].mesh];
            float t, u, v;
            bool back;
            bool hit = rd_ray_triangle(a, b, w, w + 3, w + 6, a[3], b[3], &t, &u, &v, &back);
            back = back != inst[g[r].instance].neg_det; /* the object's front, as glTF keeps it */
            if (!hit)
                problem = "any-hit triangle not hit on the CPU";
            else if (!accepted(m->flags[gtri], back, u, flags))
                problem = "any-hit triangle rejected on the CPU";
            else if (!test_close_rel(gt, t, 1e-4) || (g[r].backface != 0) != back)
                problem = "any-hit record differs";
        } else if (gh) {
            bool same = g[r].instance == c.instance && gtri == c.tri;
            if (!same && !test_close_rel(gt, c.t, 1e-4))
                problem = "different closest hit";
            else if (same &&
                     (!test_close_rel(gt, c.t, 1e-4) || (g[r].backface != 0) != c.backface ||
                      fabsf(gu - c.u) > 1e-3f || fabsf(gv - c.v) > 1e-3f))
                problem = "hit record differs";
        }
        if (!problem) continue;
        if (amb) {
            ambiguous++;
            continue;
        }
        if (bad < 8)
            fprintf(stderr,
                    "%s: ray %u o=(%g %g %g) d=(%g %g %g) [%g, %g]: %s: GPU hit=%u t=%.7g "
                    "inst=%u tri=%u back=%u; CPU hit=%d t=%.7g inst=%u tri=%u back=%d\n",
                    what, r, a[0], a[1], a[2], b[0], b[1], b[2], a[3], b[3], problem, g[r].hit, gt,
                    g[r].instance, gtri, g[r].backface, c.hit, c.t, c.instance, c.tri, c.backface);
        bad++;
    }
    CHECKF(bad == 0, "%s: %u of %d rays differ from the CPU", what, bad, RAYS);
    CHECKF(hits > RAYS / 3, "%s: only %u CPU hits", what, hits);
    fprintf(stderr, "%s: %u hits, %u ambiguous (edge or cut-out within %g)\n", what, hits,
            ambiguous, EDGE_EPS);
    return ambiguous;
}

int main(void)
{
    rd_vk vk;
    rd_vk_result rc = rd_vk_create(&vk, NULL, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc != RD_VK_OK) return test_finish();
    fprintf(stderr, "device: %s\n", vk.device_name);

    /* meshes and BLASes in one node / triangle array, indices made absolute */
    mesh meshes[MESHES] = {0};
    make_soup(&meshes[0], 300);
    make_cube(&meshes[1]);
    uint32_t node_total = 0, tri_total = 0;
    for (int m = 0; m < MESHES; m++) {
        CHECK(rd_bvh_build_triangles(&meshes[m].bvh, meshes[m].pos, meshes[m].n, NULL));
        meshes[m].node_base = node_total;
        meshes[m].tri_base = tri_total;
        node_total += meshes[m].bvh.node_count;
        tri_total += meshes[m].n;
    }
    pc_bvh_node *blas = malloc(node_total * sizeof *blas);
    pc_tri *tris = malloc(tri_total * sizeof *tris);
    for (int m = 0; m < MESHES; m++) {
        const mesh *me = &meshes[m];
        for (uint32_t i = 0; i < me->bvh.node_count; i++) {
            pc_bvh_node n = me->bvh.nodes[i];
            uint32_t first = rd_bvh_node_first(&n), count = rd_bvh_node_count(&n);
            n.bmin.w = pc_u2f(first + (count ? me->tri_base : me->node_base));
            blas[me->node_base + i] = n;
        }
        for (uint32_t k = 0; k < me->n; k++) {
            uint32_t src = me->bvh.prim_index[k];
            const float *p = me->pos + 9 * src;
            pc_tri *t = &tris[me->tri_base + k];
            *t = (pc_tri){{p[0], p[1], p[2], pc_u2f(0)},
                          {p[3], p[4], p[5], pc_u2f(me->flags[src])},
                          {p[6], p[7], p[8], pc_u2f(src)}};
        }
    }

    instance inst[INSTANCES] = {0};
    make_transform(&inst[0], (double[3]){1, 2, 3}, 0.7, (double[3]){1.5, 0.7, 1.2},
                   (double[3]){3, 0, 0});
    inst[0].mesh = 0;
    make_transform(&inst[1], (double[3]){0, 1, 0.3}, -0.4, (double[3]){-1, 1, 1},
                   (double[3]){-3, 0.5, 0});
    inst[1].mesh = 0;
    make_transform(&inst[2], (double[3]){-1, 1, 0}, 1.1, (double[3]){0.8, 0.8, 0.8},
                   (double[3]){0, 3, 1});
    inst[2].mesh = 1;
    make_transform(&inst[3], (double[3]){0, 0, 1}, 0.2, (double[3]){-0.9, -1.1, 1},
                   (double[3]){0.5, -3, -0.5});
    inst[3].mesh = 1;
    make_transform(&inst[4], (double[3]){0, 0, 1}, 0.0, (double[3]){1, 1, 1},
                   (double[3]){4, 4.5, -4});
    inst[4].mesh = 1;
    inst[4].exact = true;
    CHECK(inst[1].neg_det && !inst[0].neg_det && !inst[3].neg_det);

    pc_instance gi[INSTANCES];
    float tlo[3 * INSTANCES], thi[3 * INSTANCES];
    for (int k = 0; k < INSTANCES; k++) {
        const mesh *m = &meshes[inst[k].mesh];
        inst[k].world = malloc(m->n * 9 * sizeof(float));
        for (uint32_t i = 0; i < 3 * m->n; i++)
            xform(inst[k].m, m->pos + 3 * i, inst[k].world + 3 * i);
        for (int r = 0; r < 3; r++) {
            gi[k].object_to_world[r] = (pc_vec4){(float)inst[k].m[r][0], (float)inst[k].m[r][1],
                                                 (float)inst[k].m[r][2], (float)inst[k].m[r][3]};
            gi[k].world_to_object[r] =
                (pc_vec4){(float)inst[k].inv[r][0], (float)inst[k].inv[r][1],
                          (float)inst[k].inv[r][2], (float)inst[k].inv[r][3]};
        }
        gi[k].info = (pc_uvec4){m->node_base, inst[k].mesh, 0u, (uint32_t)k};
        /* world box of the BLAS root box's corners, widened for the float transform */
        const pc_bvh_node *root = &m->bvh.nodes[0];
        for (int a = 0; a < 3; a++) {
            tlo[3 * k + a] = INFINITY;
            thi[3 * k + a] = -INFINITY;
        }
        for (int c = 0; c < 8; c++) {
            float p[3] = {(c & 1) ? root->bmax.x : root->bmin.x,
                          (c & 2) ? root->bmax.y : root->bmin.y,
                          (c & 4) ? root->bmax.z : root->bmin.z};
            float w[3];
            xform(inst[k].m, p, w);
            for (int a = 0; a < 3; a++) {
                tlo[3 * k + a] = fminf(tlo[3 * k + a], w[a] - 1e-4f);
                thi[3 * k + a] = fmaxf(thi[3 * k + a], w[a] + 1e-4f);
            }
        }
    }

    /* TLAS 0: built, one instance per leaf; TLAS 1: one leaf holding all four instances */
    rd_bvh tlas_bvh;
    CHECK(rd_bvh_build(&tlas_bvh, tlo, thi, INSTANCES, &(rd_bvh_options){.max_leaf = 1}));
    CHECK(tlas_bvh.node_count == 2 * INSTANCES - 1);
    pc_bvh_node one_leaf = tlas_bvh.nodes[0];
    one_leaf.bmin.w = pc_u2f(0);
    one_leaf.bmax.w = pc_u2f(INSTANCES);
    const uint32_t identity[INSTANCES] = {0, 1, 2, 3, 4};

    float *rays = malloc(RAYS * 8 * sizeof(float));
    gpu_hit *res = malloc(RAYS * sizeof *res);
    make_rays(rays, inst, meshes);

    rd_pipeline pipe = {0};
    rd_buffer b_nodes = {0}, b_tris = {0}, b_inst = {0}, b_tlas[2] = {{0}}, b_index[2] = {{0}},
              b_globals[2] = {{0}}, b_rays = {0}, b_res = {0};
    VK_CHECK(rd_pipeline_create(&vk, &pipe, "test_trace", pc_spv_test_trace,
                                sizeof pc_spv_test_trace, sizeof(pc_push), err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_nodes, node_total * sizeof *blas, RD_MEMORY_DEVICE, err,
                              sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_nodes, 0, blas, node_total * sizeof *blas, err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_tris, tri_total * sizeof *tris, RD_MEMORY_DEVICE, err,
                              sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_tris, 0, tris, tri_total * sizeof *tris, err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_inst, sizeof gi, RD_MEMORY_DEVICE, err, sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_inst, 0, gi, sizeof gi, err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_rays, RAYS * 8 * sizeof(float), RD_MEMORY_DEVICE, err,
                              sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_rays, 0, rays, RAYS * 8 * sizeof(float), err, sizeof err));
    VK_CHECK(
        rd_buffer_create(&vk, &b_res, RAYS * sizeof *res, RD_MEMORY_READBACK, err, sizeof err));
    for (int v = 0; v < 2; v++) {
        const pc_bvh_node *tn = v == 0 ? tlas_bvh.nodes : &one_leaf;
        uint32_t tn_count = v == 0 ? tlas_bvh.node_count : 1;
        const uint32_t *index = v == 0 ? tlas_bvh.prim_index : identity;
        VK_CHECK(rd_buffer_create(&vk, &b_tlas[v], tn_count * sizeof *tn, RD_MEMORY_DEVICE, err,
                                  sizeof err));
        VK_CHECK(rd_buffer_upload(&vk, &b_tlas[v], 0, tn, tn_count * sizeof *tn, err, sizeof err));
        VK_CHECK(
            rd_buffer_create(&vk, &b_index[v], sizeof identity, RD_MEMORY_DEVICE, err, sizeof err));
        VK_CHECK(rd_buffer_upload(&vk, &b_index[v], 0, index, sizeof identity, err, sizeof err));
        pc_globals g = {0};
        g.scene.tris = b_tris.address;
        g.scene.blas_nodes = b_nodes.address;
        g.scene.tlas_nodes = b_tlas[v].address;
        g.scene.tlas_index = b_index[v].address;
        g.scene.instances = b_inst.address;
        g.scene.counts = (pc_uvec4){INSTANCES, 0, 0, 0};
        VK_CHECK(rd_buffer_create(&vk, &b_globals[v], sizeof g, RD_MEMORY_DEVICE, err, sizeof err));
        VK_CHECK(rd_buffer_upload(&vk, &b_globals[v], 0, &g, sizeof g, err, sizeof err));
    }

    const uint32_t variants[4] = {0, PC_TRACE_ANY_HIT, PC_TRACE_CULL_BACKFACES,
                                  PC_TRACE_ANY_HIT | PC_TRACE_CULL_BACKFACES};
    uint32_t ambiguous = 0;
    for (int v = 0; v < 2; v++) {
        for (int f = 0; f < 4; f++) {
            rd_cmd c;
            VK_CHECK(rd_buffer_fill(&vk, &b_res, 0xffffffffu, err, sizeof err));
            VK_CHECK(rd_cmd_begin(&vk, &c, err, sizeof err));
            pc_push push = {.globals = b_globals[v].address,
                            .buf0 = b_rays.address,
                            .buf1 = b_res.address,
                            .params = {RAYS, variants[f], 0, 0}};
            rd_cmd_dispatch(&c, &pipe, &push, (RAYS + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
            rd_cmd_barrier(&c);
            VK_CHECK(rd_cmd_submit_wait(&vk, &c, err, sizeof err));
            VK_CHECK(rd_buffer_download(&vk, &b_res, 0, res, RAYS * sizeof *res, err, sizeof err));
            char what[96];
            snprintf(what, sizeof what, "%s TLAS, flags %u", v == 0 ? "built" : "one-leaf",
                     variants[f]);
            ambiguous += compare(what, rays, res, meshes, inst, tris, tri_total, variants[f]);
        }
    }
    CHECKF(ambiguous <= 8 * RAYS / 100, "%u ambiguous rays", ambiguous);

done:
    rd_buffer_destroy(&vk, &b_nodes);
    rd_buffer_destroy(&vk, &b_tris);
    rd_buffer_destroy(&vk, &b_inst);
    rd_buffer_destroy(&vk, &b_rays);
    rd_buffer_destroy(&vk, &b_res);
    for (int v = 0; v < 2; v++) {
        rd_buffer_destroy(&vk, &b_tlas[v]);
        rd_buffer_destroy(&vk, &b_index[v]);
        rd_buffer_destroy(&vk, &b_globals[v]);
    }
    rd_pipeline_destroy(&vk, &pipe);
    unsigned messages = rd_vk_validation_messages(&vk);
    CHECKF(messages == 0, "%u validation messages", messages);
    rd_vk_destroy(&vk);
    rd_bvh_destroy(&tlas_bvh);
    for (int m = 0; m < MESHES; m++) {
        rd_bvh_destroy(&meshes[m].bvh);
        free(meshes[m].pos);
        free(meshes[m].flags);
    }
    for (int k = 0; k < INSTANCES; k++)
        free(inst[k].world);
    free(blas);
    free(tris);
    free(rays);
    free(res);
    return test_finish();
}
