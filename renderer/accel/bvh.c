/* bvh.c: BVH node accessors, the SAH cost of a built tree, the watertight ray/triangle test,
 * the self-intersection offset and the CPU traversal. The builders are bvh_build.c (the
 * renderer's) and bvh_build_ref.c (the reference it is measured against).
 */
#include "renderer/accel/bvh.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/bvh_internal.h"

/* Ize, "Robust BVH Ray Traversal" (JCGT 2013): scaling the far slab distance by 1 + 2*gamma(3)
 * makes the float slab test conservative. */
#define BOX_TFAR_SCALE 1.0000004f
/* Boxes are culled against the closest hit plus this relative slack: a triangle's computed t
 * can lie a few ulps before the entry distance of its own (conservative) box, so culling at
 * exactly t_best could lose a coplanar, overlapping triangle that brute force returns. */
#define CULL_SLACK (1.0f / 65536.0f)

uint32_t rd_bvh_node_first(const pc_bvh_node *n)
{
    return pc_f2u(n->bmin.w);
}

uint32_t rd_bvh_node_count(const pc_bvh_node *n)
{
    return pc_f2u(n->bmax.w);
}

double rd_bvh_sah_cost(const rd_bvh *bvh)
{
    if (!bvh->nodes || bvh->node_count == 0) return 0.0;
    const pc_bvh_node *r = &bvh->nodes[0];
    const float rlo[3] = {r->bmin.x, r->bmin.y, r->bmin.z},
                rhi[3] = {r->bmax.x, r->bmax.y, r->bmax.z};
    double root = bvh_half_area(rlo, rhi);
    if (!(root > 0.0)) return 0.0;
    double cost = 0.0;
    for (uint32_t i = 0; i < bvh->node_count; i++) {
        const pc_bvh_node *n = &bvh->nodes[i];
        const float lo[3] = {n->bmin.x, n->bmin.y, n->bmin.z},
                    hi[3] = {n->bmax.x, n->bmax.y, n->bmax.z};
        uint32_t count = rd_bvh_node_count(n);
        double a = bvh_half_area(lo, hi);
        cost += count ? SAH_INTERSECT * a * count : SAH_TRAVERSAL * a;
    }
    return cost / root;
}

void rd_bvh_destroy(rd_bvh *bvh)
{
    if (!bvh) return;
    free(bvh->nodes);
    free(bvh->prim_index);
    memset(bvh, 0, sizeof *bvh);
}

/* ---- ray / triangle ------------------------------------------------------------------------ */

/* Per-ray part of the watertight test: kz is the dominant direction axis; kx, ky are swapped
 * when dir[kz] < 0 to keep the winding; S shears the ray to +z (Woop et al. 2013, sec. 3). */
typedef struct ray_shear {
    int kx, ky, kz;
    float sx, sy, sz;
} ray_shear;

static void shear_init(const float dir[3], ray_shear *s)
{
    float ax = fabsf(dir[0]), ay = fabsf(dir[1]), az = fabsf(dir[2]);
    int kz = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (dir[kz] < 0.0f) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    s->kx = kx;
    s->ky = ky;
    s->kz = kz;
    s->sx = dir[kx] / dir[kz];
    s->sy = dir[ky] / dir[kz];
    s->sz = 1.0f / dir[kz];
}

/* Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013, fig. 2/3.
 * Front = counter-clockwise: det > 0 exactly when dot(dir, cross(v1-v0, v2-v0)) < 0. */
static bool tri_hit(const ray_shear *s, const float org[3], const float v0[3], const float v1[3],
                    const float v2[3], float tmin, float tmax, float *t_out, float *u_out,
                    float *v_out, bool *back_out)
{
    const int kx = s->kx, ky = s->ky, kz = s->kz;
    float A[3] = {v0[0] - org[0], v0[1] - org[1], v0[2] - org[2]};
    float B[3] = {v1[0] - org[0], v1[1] - org[1], v1[2] - org[2]};
    float C[3] = {v2[0] - org[0], v2[1] - org[1], v2[2] - org[2]};
    float Ax = A[kx] - s->sx * A[kz], Ay = A[ky] - s->sy * A[kz];
    float Bx = B[kx] - s->sx * B[kz], By = B[ky] - s->sy * B[kz];
    float Cx = C[kx] - s->sx * C[kz], Cy = C[ky] - s->sy * C[kz];
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
    /* An edge function that is exactly 0 may be a rounding artefact: redo all three in
     * double, where the products of floats are exact (paper, sec. 3.3). */
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        U = (float)((double)Cx * By - (double)Cy * Bx);
        V = (float)((double)Ax * Cy - (double)Ay * Cx);
        W = (float)((double)Bx * Ay - (double)By * Ax);
    }
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return false;
    float det = U + V + W;
    if (det == 0.0f || !(fabsf(det) <= FLT_MAX)) /* also rejects NaN/Inf vertices */
        return false;
    float Az = s->sz * A[kz], Bz = s->sz * B[kz], Cz = s->sz * C[kz];
    float T = U * Az + V * Bz + W * Cz;
    float rcp = 1.0f / det;
    float t = T * rcp;
    if (!(t > tmin && t < tmax)) return false;
    *t_out = t;
    *u_out = V * rcp;
    *v_out = W * rcp;
    *back_out = det < 0.0f;
    return true;
}

bool rd_ray_triangle(const float org[3], const float dir[3], const float v0[3], const float v1[3],
                     const float v2[3], float tmin, float tmax, float *t, float *u, float *v,
                     bool *backface)
{
    ray_shear s;
    shear_init(dir, &s);
    return tri_hit(&s, org, v0, v1, v2, tmin, tmax, t, u, v, backface);
}

/* ---- offset ---------------------------------------------------------------------------------- */

float rd_ray_offset_distance(float scale)
{
    float d = (float)PC_RAY_OFFSET_REL * scale;
    return d < 3.0e38f ? fmaxf(d, (float)PC_RAY_OFFSET_MIN) : 0.0f; /* NaN, Inf -> none */
}

void rd_offset_ray_origin(const float p[3], const float n[3], float offset, float out[3])
{
    for (int a = 0; a < 3; a++)
        out[a] = p[a] + n[a] * offset;
}

/* ---- CPU traversal ----------------------------------------------------------------------------
 */

typedef struct ray_box {
    float org[3];
    float inv[3];
    int neg[3];
} ray_box;

/* NaN-ignoring max/min: x NaN -> acc (acc starts at tmin/tmax, never NaN). */
static inline float max_nn(float x, float acc)
{
    return x > acc ? x : acc;
}

static inline float min_nn(float x, float acc)
{
    return x < acc ? x : acc;
}

/* Slab test (Williams et al. 2005 with Ize 2013's conservative far scale): near/far planes
 * chosen by the direction sign, so inverted (empty) boxes are always rejected; a zero
 * direction component gives +-inf reciprocals, and the NaN of 0 * inf is ignored. */
static bool box_hit(const ray_box *r, const pc_bvh_node *n, float tmin, float tmax, float *tnear)
{
    const float lo[3] = {n->bmin.x, n->bmin.y, n->bmin.z};
    const float hi[3] = {n->bmax.x, n->bmax.y, n->bmax.z};
    float tn = tmin, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        float near_plane = r->neg[a] ? hi[a] : lo[a];
        float far_plane = r->neg[a] ? lo[a] : hi[a];
        tn = max_nn((near_plane - r->org[a]) * r->inv[a], tn);
        tf = min_nn((far_plane - r->org[a]) * r->inv[a], tf);
    }
    tf = min_nn(tf * BOX_TFAR_SCALE, tmax);
    *tnear = tn;
    return tn <= tf;
}

int64_t rd_bvh_closest_triangle(const rd_bvh *bvh, const float *positions, const float org[3],
                                const float dir[3], float tmin, float tmax, float *t_out)
{
    if (!bvh->nodes || bvh->node_count == 0) return -1;
    for (int a = 0; a < 3; a++) {
        if (!isfinite(org[a]) || !isfinite(dir[a])) return -1;
    }
    ray_box r;
    for (int a = 0; a < 3; a++) {
        r.org[a] = org[a];
        r.inv[a] = 1.0f / dir[a];
        r.neg[a] = r.inv[a] < 0.0f;
    }
    ray_shear s;
    shear_init(dir, &s);

    float best = tmax, cull = tmax, tn0, tn1;
    int64_t hit = -1;
    if (!box_hit(&r, &bvh->nodes[0], tmin, best, &tn0)) return -1;

    struct {
        uint32_t node;
        float tnear;
    } stack[PC_BVH_STACK_SIZE];
    int sp = 0;
    uint32_t node = 0;
    for (;;) {
        const pc_bvh_node *n = &bvh->nodes[node];
        uint32_t first = rd_bvh_node_first(n), count = rd_bvh_node_count(n);
        bool descend = false;
        if (count == 0) {
            assert(first + 1 < bvh->node_count);
            bool h0 = box_hit(&r, &bvh->nodes[first], tmin, cull, &tn0);
            bool h1 = box_hit(&r, &bvh->nodes[first + 1], tmin, cull, &tn1);
            if (h0 && h1) {
                bool swap = tn1 < tn0;
                assert(sp < PC_BVH_STACK_SIZE);
                stack[sp].node = swap ? first : first + 1;
                stack[sp].tnear = swap ? tn0 : tn1;
                sp++;
                node = swap ? first + 1 : first;
                descend = true;
            } else if (h0 || h1) {
                node = h0 ? first : first + 1;
                descend = true;
            }
        } else {
            for (uint32_t i = first; i < first + count; i++) {
                uint32_t tri = bvh->prim_index[i];
                const float *v = positions + 9 * (size_t)tri;
                float t, u, vv;
                bool back;
                if (tri_hit(&s, org, v, v + 3, v + 6, tmin, best, &t, &u, &vv, &back)) {
                    best = t;
                    cull = t + fabsf(t) * CULL_SLACK;
                    hit = tri;
                }
            }
        }
        if (descend) continue;
        /* Pop, skipping nodes entered farther than the closest hit so far. */
        for (;;) {
            if (sp == 0) {
                if (hit >= 0 && t_out) *t_out = best;
                return hit;
            }
            sp--;
            if (stack[sp].tnear <= cull) break;
        }
        node = stack[sp].node;
    }
}
