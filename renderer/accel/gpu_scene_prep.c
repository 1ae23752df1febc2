/* gpu_scene_prep.c: the CPU half of a GPU scene's creation (gpu_scene.h, rd_gpu_scene_prepare):
 * every mesh's bottom-level BVH, its local origin, and the triangle records in leaf order. No
 * Vulkan: it runs on the uploading connection's thread in the daemon. */
#include "renderer/accel/gpu_scene.h"

#include <math.h>
#include <string.h>

#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "renderer/scene/xform.h"

/* Octahedral encoding of a unit vector (Cigolle et al., JCGT 2014) as packSnorm2x16 bits;
 * shaders/common.glsl decodes it. */
static uint32_t pack_octahedral(const float v[3])
{
    float l1 = fabsf(v[0]) + fabsf(v[1]) + fabsf(v[2]);
    float x = l1 > 0 ? v[0] / l1 : 0, y = l1 > 0 ? v[1] / l1 : 0;
    if (v[2] < 0) {
        float ox = (1.0f - fabsf(y)) * (x >= 0 ? 1.0f : -1.0f);
        float oy = (1.0f - fabsf(x)) * (y >= 0 ? 1.0f : -1.0f);
        x = ox, y = oy;
    }
    int32_t ix = (int32_t)lrintf(clamp01(x * 0.5f + 0.5f) * 65534.0f) - 32767;
    int32_t iy = (int32_t)lrintf(clamp01(y * 0.5f + 0.5f) * 65534.0f) - 32767;
    return ((uint32_t)ix & 0xffffu) | ((uint32_t)iy & 0xffffu) << 16;
}

/* The triangle's TANGENT attribute in pc_tri_attr.tangents form (zero when the mesh has none
 * or a tangent is not a finite non-zero vector: the shader then derives one from the UVs). */
static pc_uvec4 pack_tangents(const float *t)
{
    pc_uvec4 out = {0, 0, 0, 0};
    if (!t) return out;
    uint32_t packed[3], flags = PC_TANGENT_PRESENT;
    for (int k = 0; k < 3; k++) {
        const float *v = t + 4 * k;
        float len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (!(len > 1e-12f) || !isfinite(len)) return out;
        const float u[3] = {v[0] / len, v[1] / len, v[2] / len};
        packed[k] = pack_octahedral(u);
        if (v[3] < 0) flags |= PC_TANGENT_FLIP << k;
    }
    out = (pc_uvec4){packed[0], packed[1], packed[2], flags};
    return out;
}

/* The local origin of a mesh whose object-space box is b (min, max): none (0) when the box's
 * centre lies within 16 times the box's largest side of the origin, where the vertices lose at
 * most 4 bits to their distance (ray offsets cover it: they scale with the local vertices); else
 * the centre, rounded to a multiple of the largest power of two not above that side, so that
 * vertices minus the origin are mostly exact. */
static void mesh_local_origin(const float b[6], float origin[3])
{
    float side = 0, far = 0, c[3];
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * b[k] + 0.5f * b[3 + k];
        side = fmaxf(side, b[3 + k] - b[k]);
        far = fmaxf(far, fabsf(c[k]));
        origin[k] = 0;
    }
    if (!(side > 0) || !isfinite(side) || !isfinite(far) || far <= 16 * side) return;
    int e;
    frexpf(side, &e); /* side in [2^(e-1), 2^e) */
    for (int k = 0; k < 3; k++)
        origin[k] = ldexpf(rintf(ldexpf(c[k], 1 - e)), e - 1);
}

/* a - c rounded down and up (a float, c a local origin): BLAS boxes move into the local frame
 * without losing a triangle that the rounded vertices a - c of their own may reach. */
static float sub_down(float a, float c)
{
    double r = (double)a - (double)c;
    float f = (float)r;
    return (double)f > r ? nextafterf(f, -INFINITY) : f;
}
static float sub_up(float a, float c)
{
    double r = (double)a - (double)c;
    float f = (float)r;
    return (double)f < r ? nextafterf(f, INFINITY) : f;
}

/* v - origin, rounded once: a vertex in its mesh's local frame. */
static pc_vec4 local_vertex(const float *v, const float origin[3], float w)
{
    return (pc_vec4){(float)((double)v[0] - origin[0]), (float)((double)v[1] - origin[1]),
                     (float)((double)v[2] - origin[2]), w};
}

void rd_gpu_scene_fill_mesh(const rd_scene *s, uint32_t m, const rd_bvh *bvh, const float o[3],
                            uint32_t node_base, uint32_t tri_base, pc_bvh_node *nodes, pc_tri *tris,
                            pc_tri_attr *attrs)
{
    const rd_mesh *mesh = &s->meshes[m];
    bool local = o[0] != 0 || o[1] != 0 || o[2] != 0;
    for (uint32_t i = 0; i < bvh->node_count; i++) {
        pc_bvh_node n = bvh->nodes[i];
        uint32_t first = rd_bvh_node_first(&n), count = rd_bvh_node_count(&n);
        n.bmin.w = pc_u2f(first + (count ? tri_base : node_base));
        if (local) { /* empty boxes [+inf, -inf] stay empty */
            n.bmin.x = sub_down(n.bmin.x, o[0]), n.bmax.x = sub_up(n.bmax.x, o[0]);
            n.bmin.y = sub_down(n.bmin.y, o[1]), n.bmax.y = sub_up(n.bmax.y, o[1]);
            n.bmin.z = sub_down(n.bmin.z, o[2]), n.bmax.z = sub_up(n.bmax.z, o[2]);
        }
        nodes[i] = n;
    }
    for (uint32_t i = 0; i < bvh->prim_count; i++) {
        uint32_t src = bvh->prim_index[i];
        uint32_t mat = mesh->material[src] < s->material_count ? mesh->material[src] : 0;
        const rd_material *mm = &s->materials[mat];
        uint32_t flags = (mm->double_sided ? PC_TRI_DOUBLE_SIDED : 0) |
                         (mm->alpha_mode == RD_ALPHA_MASK ? PC_TRI_ALPHA_MASK : 0);
        const float *pos = &mesh->positions[src * 9];
        const float *n = &mesh->normals[src * 9];
        const float *uv = &mesh->uvs[src * 6];
        pc_tri *t = &tris[i];
        t->v0 = local_vertex(pos, o, pc_u2f(mat));
        t->v1 = local_vertex(pos + 3, o, pc_u2f(flags));
        t->v2 = local_vertex(pos + 6, o, pc_u2f(src));
        pc_tri_attr *a = &attrs[i];
        a->n0 = v4(n, 0), a->n1 = v4(n + 3, 0), a->n2 = v4(n + 6, 0);
        a->uv01 = (pc_vec4){uv[0], uv[1], uv[2], uv[3]};
        a->uv2 = (pc_vec4){uv[4], uv[5], 0, 0};
        a->tangents = pack_tangents(mesh->tangents ? &mesh->tangents[src * 12] : NULL);
    }
}

/* The box (min, max) of mesh m's triangles whose vertices are all finite, as the root of its
 * CPU build bounds them (bvh_triangle_box); empty [+inf, -inf] when there are none. */
static void mesh_box(const rd_mesh *mesh, float b[6])
{
    b[0] = b[1] = b[2] = INFINITY;
    b[3] = b[4] = b[5] = -INFINITY;
    for (uint32_t t = 0; t < mesh->tri_count; t++) {
        const float *v = &mesh->positions[9 * (size_t)t];
        bool finite = true;
        for (int k = 0; k < 9; k++)
            finite = finite && isfinite(v[k]);
        for (int k = 0; finite && k < 9; k++) {
            b[k % 3] = fminf(b[k % 3], v[k]);
            b[3 + k % 3] = fmaxf(b[3 + k % 3], v[k]);
        }
    }
}

/* Mesh m left to the GPU's LBVH: its positions in its local frame o (as its records hold them)
 * for the upload's build (rd_gpu_scene_lbvh_run). */
static void add_lbvh_job(rd_gpu_scene_lbvh_jobs *j, const rd_mesh *mesh, uint32_t m,
                         const float o[3], uint32_t node_base, uint32_t tri_base)
{
    size_t n = mesh->tri_count;
    float *pos = xcalloc(9 * n, sizeof *pos);
    for (size_t i = 0; i < 9 * n; i++)
        pos[i] = (float)((double)mesh->positions[i] - o[i % 3]);
    j->meshes[j->count++] = (rd_gpu_scene_lbvh_mesh){m, node_base, tri_base, mesh->tri_count, pos};
}

rd_vk_result rd_gpu_scene_prepare(rd_gpu_scene_prep *p, const rd_scene *s, char *err, size_t errlen)
{
    return rd_gpu_scene_prepare_device(p, s, false, err, errlen);
}

rd_vk_result rd_gpu_scene_prepare_device(rd_gpu_scene_prep *p, const rd_scene *s, bool gpu_device,
                                         char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    double t0 = now_ms();
    p->mesh_count = s->mesh_count;
    p->mesh_root = xcalloc(s->mesh_count, sizeof *p->mesh_root);
    p->mesh_bounds = xcalloc(s->mesh_count, 6 * sizeof(float));
    p->mesh_origin = xcalloc(s->mesh_count, 3 * sizeof(float));
    p->mesh_local_bounds = xcalloc(s->mesh_count, 6 * sizeof(float));
    p->mesh_revision = xcalloc(s->mesh_count, sizeof *p->mesh_revision);
    rd_bvh *bvhs = xcalloc(s->mesh_count, sizeof *bvhs);
    rd_bvh_mesh *meshes = xcalloc(s->mesh_count, sizeof *meshes);
    /* static meshes the GPU builds at upload (PROBECAST_BLAS_BUILD): no CPU build here */
    rd_blas_build policy = rd_blas_build_from_env();
    uint8_t *on_gpu = xcalloc(s->mesh_count, 1);
    uint32_t gpu_count = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        on_gpu[m] = !mesh->deform && rd_blas_build_on_gpu(policy, gpu_device, mesh->tri_count);
        gpu_count += on_gpu[m];
        meshes[m] = (rd_bvh_mesh){mesh->positions, on_gpu[m] ? 0 : mesh->tri_count};
    }
    /* Every mesh's BLAS at once, on all cores (this runs off the render thread). */
    if (!rd_bvh_build_many(bvhs, meshes, s->mesh_count, NULL)) {
        fprintf(stderr, "probecast: out of memory building a BVH\n");
        abort();
    }
    free(meshes);
    uint64_t tri_total = 0, node_total = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        p->mesh_root[m] = (uint32_t)node_total;
        float *b = &p->mesh_bounds[m * 6];
        if (on_gpu[m]) {
            mesh_box(mesh, b);
        } else {
            const pc_bvh_node *root = &bvhs[m].nodes[0];
            b[0] = root->bmin.x, b[1] = root->bmin.y, b[2] = root->bmin.z;
            b[3] = root->bmax.x, b[4] = root->bmax.y, b[5] = root->bmax.z;
        }
        float *o = &p->mesh_origin[m * 3], *lb = &p->mesh_local_bounds[m * 6];
        if (!mesh->deform) mesh_local_origin(b, o); /* a deforming mesh keeps 0: it is rebuilt */
        for (int k = 0; k < 3; k++) {
            lb[k] = sub_down(b[k], o[k]);
            lb[3 + k] = sub_up(b[3 + k], o[k]);
        }
        if (bvhs[m].depth > p->max_blas_depth) p->max_blas_depth = bvhs[m].depth;
        tri_total += mesh->tri_count;
        node_total += on_gpu[m] ? rd_gpu_lbvh_node_count(mesh->tri_count)
                                : blas_slots(mesh, bvhs[m].node_count);
    }
    p->tri_count = tri_total;
    p->node_count = node_total;
    if (tri_total > UINT32_MAX / 2 || node_total > UINT32_MAX / 2) {
        for (uint32_t m = 0; m < s->mesh_count; m++)
            rd_bvh_destroy(&bvhs[m]);
        free(bvhs);
        free(on_gpu);
        rd_gpu_scene_prep_destroy(p);
        snprintf(err, errlen, "scene too large: %llu triangles", (unsigned long long)tri_total);
        return RD_VK_ERR_OUT_OF_MEMORY;
    }

    p->nodes = xcalloc(node_total, sizeof *p->nodes);
    p->tris = xcalloc(tri_total, sizeof *p->tris);
    p->attrs = xcalloc(tri_total, sizeof *p->attrs);
    if (gpu_count) {
        p->lbvh_jobs = xcalloc(1, sizeof *p->lbvh_jobs);
        p->lbvh_jobs->method =
            policy == RD_BLAS_BUILD_GPU_PLOC ? RD_GPU_BVH_PLOC : RD_GPU_BVH_LBVH;
        p->lbvh_jobs->meshes = xcalloc(gpu_count, sizeof *p->lbvh_jobs->meshes);
    }
    uint32_t node_base = 0, tri_base = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        const float *o = &p->mesh_origin[m * 3];
        if (on_gpu[m]) { /* records in original order, no nodes: the GPU places both */
            rd_bvh_destroy(&bvhs[m]);
            bvhs[m].prim_index = xcalloc(mesh->tri_count, sizeof *bvhs[m].prim_index);
            bvhs[m].prim_count = mesh->tri_count;
            for (uint32_t i = 0; i < mesh->tri_count; i++)
                bvhs[m].prim_index[i] = i;
            add_lbvh_job(p->lbvh_jobs, mesh, m, o, node_base, tri_base);
        }
        rd_gpu_scene_fill_mesh(s, m, &bvhs[m], o, node_base, tri_base, p->nodes + node_base,
                               p->tris + tri_base, p->attrs + tri_base);
        node_base += (uint32_t)(on_gpu[m] ? rd_gpu_lbvh_node_count(mesh->tri_count)
                                          : blas_slots(mesh, bvhs[m].node_count));
        tri_base += mesh->tri_count;
        p->mesh_revision[m] = mesh->deform ? mesh->deform->revision : 0;
        rd_bvh_destroy(&bvhs[m]);
    }
    free(bvhs);
    free(on_gpu);
    p->build_ms = now_ms() - t0;
    return RD_VK_OK;
}

void rd_gpu_scene_prep_destroy(rd_gpu_scene_prep *p)
{
    free(p->mesh_root);
    free(p->mesh_bounds);
    free(p->mesh_origin);
    free(p->mesh_local_bounds);
    free(p->mesh_revision);
    free(p->nodes);
    free(p->tris);
    free(p->attrs);
    rd_gpu_scene_lbvh_jobs_free(p->lbvh_jobs);
    memset(p, 0, sizeof *p);
}
