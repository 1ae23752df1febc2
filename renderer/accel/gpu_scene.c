/* gpu_scene.c: the GPU half of a GPU scene (gpu_scene.h): buffers, uploads or staged copies,
 * the top level over instances, lights (materials and textures: gpu_scene_materials.c). The CPU
 * half (BVHs, triangle records) is gpu_scene_prep.c. */
#include "renderer/accel/gpu_scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "renderer/scene/xform.h"

/* Uploads (or stages) the prepared BLAS nodes and triangle records, then frees them; the mesh
 * tables move into gs. */
static rd_vk_result upload_blas(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs, rd_gpu_scene_prep *p,
                                char *err, size_t errlen)
{
    gs->mesh_count = p->mesh_count;
    gs->mesh_root = p->mesh_root;
    gs->mesh_bounds = p->mesh_bounds;
    gs->mesh_origin = p->mesh_origin;
    gs->mesh_local_bounds = p->mesh_local_bounds;
    gs->mesh_revision = p->mesh_revision;
    gs->lbvh_jobs = p->lbvh_jobs; /* built on the GPU after the copies (rd_gpu_scene_lbvh_run) */
    p->lbvh_jobs = NULL;
    p->mesh_revision = NULL;
    p->mesh_root = NULL;
    p->mesh_bounds = NULL;
    p->mesh_origin = NULL;
    p->mesh_local_bounds = NULL;
    gs->blas_build_ms = p->build_ms;
    gs->tri_count = p->tri_count;
    gs->blas_node_count = p->node_count;
    gs->max_blas_depth = p->max_blas_depth;
    double t1 = now_ms();
    rd_vk_result r = rd_gpu_scene_upload_new(vk, st, &gs->blas_nodes, p->nodes,
                                             sizeof *p->nodes * p->node_count, err, errlen);
    if (r == RD_VK_OK)
        r = rd_gpu_scene_upload_new(vk, st, &gs->tris, p->tris, sizeof *p->tris * p->tri_count, err,
                                    errlen);
    if (r == RD_VK_OK)
        r = rd_gpu_scene_upload_new(vk, st, &gs->tri_attrs, p->attrs,
                                    sizeof *p->attrs * p->tri_count, err, errlen);
    gs->upload_ms += now_ms() - t1;
    /* copied (or staged): the host's copies go now, not with the prep, which lowers the peak */
    free(p->nodes);
    free(p->tris);
    free(p->attrs);
    p->nodes = NULL;
    p->tris = NULL;
    p->attrs = NULL;
    return r;
}

/* World box of a mesh's object-space box under m (the 8 transformed corners). */
static void world_box(const float m[16], const float *b, float *lo, float *hi)
{
    lo[0] = lo[1] = lo[2] = INFINITY;
    hi[0] = hi[1] = hi[2] = -INFINITY;
    if (!(b[0] <= b[3] && b[1] <= b[4] && b[2] <= b[5])) return; /* empty mesh */
    for (int c = 0; c < 8; c++) {
        float p[3] = {b[(c & 1) ? 3 : 0], b[(c & 2) ? 4 : 1], b[(c & 4) ? 5 : 2]}, w[3];
        rd_mat4_transform_point(m, p, w);
        for (int k = 0; k < 3; k++) {
            if (w[k] < lo[k]) lo[k] = w[k];
            if (w[k] > hi[k]) hi[k] = w[k];
        }
    }
    /* the corners were rounded once: widen by a relative margin so no grazing hit is culled */
    for (int k = 0; k < 3; k++) {
        float pad = 1e-6f * fmaxf(fabsf(lo[k]), fabsf(hi[k])) + 1e-30f;
        lo[k] -= pad;
        hi[k] += pad;
    }
}

static void rows3(pc_vec4 out[3], const float m[16])
{
    for (int r = 0; r < 3; r++)
        out[r] = (pc_vec4){m[r], m[4 + r], m[8 + r], m[12 + r]};
}

/* Source of rd_gpu_scene.revision (render thread only, like all of Vulkan here). */
static uint64_t last_revision;

/* Do a and b light the scene from the same place, in the same way as rays see it (type,
 * position, range; aim for spot and directional lights; the spot's cone)? Colour and intensity
 * do not count. */
static bool same_placement(const pc_light *a, const pc_light *b)
{
    if (a->info.x != b->info.x ||
        memcmp(&a->position_range, &b->position_range, sizeof a->position_range) != 0)
        return false;
    if (a->info.x != PC_LIGHT_POINT && memcmp(&a->direction, &b->direction, sizeof a->direction))
        return false;
    return a->info.x != PC_LIGHT_SPOT || a->spot.x == b->spot.x;
}

/* Logs the box lo, hi (not empty: a singular transform's is skipped) as changed under the current
 * geometry revision. */
static void log_box(rd_gpu_scene *gs, const float *lo, const float *hi)
{
    if (!(lo[0] <= hi[0])) return;
    if (gs->dirty_count == RD_GPU_SCENE_DIRTY_MAX) {
        /* full: the older half goes, and maps older than it rebuild whole */
        uint32_t drop = RD_GPU_SCENE_DIRTY_MAX / 2;
        gs->dirty_since = gs->dirty[drop - 1].revision;
        memmove(gs->dirty, gs->dirty + drop, sizeof gs->dirty[0] * (gs->dirty_count - drop));
        gs->dirty_count -= drop;
        if (gs->dirty_since == gs->geometry_revision) gs->dirty_count = 0;
    }
    rd_gpu_scene_dirty *d = &gs->dirty[gs->dirty_count++];
    d->revision = gs->geometry_revision;
    memcpy(d->lo, lo, sizeof d->lo);
    memcpy(d->hi, hi, sizeof d->hi);
}

/* Logs where the geometry changed (gs->dirty) between the instances as last placed and inst
 * (new boxes lo, hi; n instances), under a new geometry revision when anything moved, and keeps
 * inst as the last placed. */
static void log_moves(rd_gpu_scene *gs, const pc_instance *inst, const float *lo, const float *hi,
                      uint32_t n)
{
    if (!gs->placed) { /* a new scene: nothing before it is logged */
        gs->placed = xcalloc(n ? n : 1, sizeof *gs->placed);
        memcpy(gs->placed, inst, sizeof *inst * n);
        gs->revision = gs->geometry_revision = ++last_revision;
        gs->dirty_count = 0;
        gs->dirty_since = gs->geometry_revision;
        return;
    }
    bool moved = false;
    for (uint32_t i = 0; i < n; i++) {
        if (memcmp(&gs->placed[i], &inst[i], sizeof *inst) == 0) continue;
        if (!moved) gs->revision = gs->geometry_revision = ++last_revision;
        moved = true;
        /* where it was (the box of its old placement) and where it is */
        float old_lo[3], old_hi[3], m[16] = {0};
        for (int r = 0; r < 3; r++) {
            const float *row = &gs->placed[i].object_to_world[r].x;
            m[r] = row[0], m[4 + r] = row[1], m[8 + r] = row[2], m[12 + r] = row[3];
        }
        m[15] = 1;
        world_box(m, &gs->mesh_local_bounds[gs->placed[i].info.y * 6], old_lo, old_hi);
        const float *box[2][2] = {{old_lo, old_hi}, {&lo[i * 3], &hi[i * 3]}};
        for (int b = 0; b < 2; b++) {
            log_box(gs, box[b][0], box[b][1]);
        }
        gs->placed[i] = inst[i];
    }
}

/* rd_gpu_scene_update_instances, its buffers written at once without st, staged into st with it */
static rd_vk_result update_instances(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs, const rd_scene *s,
                                     char *err, size_t errlen)
{
    double t0 = now_ms();
    uint32_t n = s->instance_count;
    if (n != gs->instance_capacity && gs->instance_capacity != 0) {
        snprintf(err, errlen, "instance count changed from %u to %u", gs->instance_capacity, n);
        return RD_VK_ERR_VULKAN;
    }
    pc_instance *inst = xcalloc(n, sizeof *inst);
    float *lo = xcalloc(n, 3 * sizeof(float)), *hi = xcalloc(n, 3 * sizeof(float));
    for (uint32_t i = 0; i < n; i++) {
        const rd_instance *in = &s->instances[i];
        /* floating origin: the GPU sees positions relative to origin_shift, and the mesh's
         * vertices relative to its local origin o: world = node (v' + o) - shift, the
         * translation summed in double and rounded once */
        float world[16];
        const float *node = s->nodes[in->node].world, *o = &gs->mesh_origin[in->mesh * 3];
        memcpy(world, node, sizeof world);
        for (int k = 0; k < 3; k++)
            world[12 + k] = (float)((double)node[k] * o[0] + (double)node[4 + k] * o[1] +
                                    (double)node[8 + k] * o[2] + (double)node[12 + k] -
                                    (double)gs->origin_shift[k]);
        float inv[16];
        bool invertible = rd_mat4_inverse(inv, world);
        rows3(inst[i].object_to_world, world);
        rows3(inst[i].world_to_object, invertible ? inv : world);
        inst[i].info = (pc_uvec4){gs->mesh_root[in->mesh], in->mesh, 0, in->node};
        if (invertible) {
            world_box(world, &gs->mesh_local_bounds[in->mesh * 6], &lo[i * 3], &hi[i * 3]);
        } else { /* a singular transform flattens the mesh: it cannot be hit */
            lo[i * 3] = lo[i * 3 + 1] = lo[i * 3 + 2] = INFINITY;
            hi[i * 3] = hi[i * 3 + 1] = hi[i * 3 + 2] = -INFINITY;
        }
    }
    log_moves(gs, inst, lo, hi, n);
    rd_bvh tlas = {0};
    if (!rd_bvh_build(&tlas, lo, hi, n, NULL)) {
        fprintf(stderr, "probecast: out of memory building the top-level BVH\n");
        abort();
    }
    free(lo);
    free(hi);
    if (tlas.node_count) {
        const pc_bvh_node *root = &tlas.nodes[0];
        const float b[6] = {root->bmin.x, root->bmin.y, root->bmin.z,
                            root->bmax.x, root->bmax.y, root->bmax.z};
        memcpy(gs->bounds, b, sizeof b);
    }
    gs->tlas_build_ms = now_ms() - t0;
    gs->tlas_node_count = tlas.node_count;

    rd_vk_result r = RD_VK_OK;
    if (gs->instance_capacity == 0) {
        /* A TLAS over n boxes has at most 2n - 1 nodes: size for the worst case once. */
        uint32_t max_nodes = n ? 2 * n : 1;
        r = rd_buffer_create(vk, &gs->instances, sizeof(pc_instance) * n, RD_MEMORY_DEVICE, err,
                             errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(vk, &gs->tlas_nodes, sizeof(pc_bvh_node) * max_nodes,
                                 RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(vk, &gs->tlas_index, sizeof(uint32_t) * (n ? n : 1),
                                 RD_MEMORY_DEVICE, err, errlen);
        gs->instance_capacity = n;
    }
    if (r == RD_VK_OK && n)
        r = rd_upload(vk, st, &gs->instances, 0, inst, sizeof *inst * n, err, errlen);
    if (r == RD_VK_OK)
        r = rd_upload(vk, st, &gs->tlas_nodes, 0, tlas.nodes, sizeof(pc_bvh_node) * tlas.node_count,
                      err, errlen);
    if (r == RD_VK_OK && n)
        r = rd_upload(vk, st, &gs->tlas_index, 0, tlas.prim_index, sizeof(uint32_t) * n, err,
                      errlen);
    rd_bvh_destroy(&tlas);
    free(inst);
    return r;
}

rd_vk_result rd_gpu_scene_update_instances(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                           char *err, size_t errlen)
{
    return update_instances(vk, NULL, gs, s, err, errlen);
}

bool rd_gpu_scene_mesh_stale(const rd_gpu_scene *gs, const rd_scene *s, uint32_t mesh)
{
    return mesh < s->mesh_count && mesh < gs->mesh_count && gs->mesh_revision &&
           s->meshes[mesh].deform && s->meshes[mesh].deform->revision != gs->mesh_revision[mesh];
}

/* The world box (GPU frame) of instance i as last placed, with its mesh's local box as gs holds
 * it now. */
static void placed_box(const rd_gpu_scene *gs, uint32_t i, float lo[3], float hi[3])
{
    float m[16] = {0};
    for (int r = 0; r < 3; r++) {
        const float *row = &gs->placed[i].object_to_world[r].x;
        m[r] = row[0], m[4 + r] = row[1], m[8 + r] = row[2], m[12 + r] = row[3];
    }
    m[15] = 1;
    world_box(m, &gs->mesh_local_bounds[gs->placed[i].info.y * 6], lo, hi);
}

/* Rebuilds the BLASes of the stale meshes list[0..n) on the CPU and writes them in place. */
static rd_vk_result rebuild_meshes(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                   const uint32_t *list, uint32_t n, char *err, size_t errlen)
{
    rd_bvh *bvhs = xcalloc(n, sizeof *bvhs);
    rd_bvh_mesh *meshes = xcalloc(n, sizeof *meshes);
    for (uint32_t k = 0; k < n; k++)
        meshes[k] = (rd_bvh_mesh){s->meshes[list[k]].positions, s->meshes[list[k]].tri_count};
    if (!rd_bvh_build_many(bvhs, meshes, n, NULL)) {
        fprintf(stderr, "probecast: out of memory building a BVH\n");
        abort();
    }
    free(meshes);
    uint32_t *tri_base = xcalloc(s->mesh_count, sizeof *tri_base), base = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        tri_base[m] = base, base += s->meshes[m].tri_count;
    rd_vk_result r = RD_VK_OK;
    for (uint32_t k = 0; k < n && r == RD_VK_OK; k++) {
        uint32_t m = list[k], tris = s->meshes[m].tri_count;
        const rd_bvh *bvh = &bvhs[k];
        if (bvh->node_count > blas_slots(&s->meshes[m], 0) || bvh->prim_count != tris) {
            snprintf(err, errlen, "the rebuilt BVH of mesh %u does not fit its slots", m);
            r = RD_VK_ERR_VULKAN; /* a broken invariant, reported */
            break;
        }
        pc_bvh_node *nodes = xcalloc(bvh->node_count, sizeof *nodes);
        pc_tri *t = xcalloc(tris, sizeof *t);
        pc_tri_attr *a = xcalloc(tris, sizeof *a);
        const float zero[3] = {0, 0, 0}; /* deforming meshes have no local origin */
        rd_gpu_scene_fill_mesh(s, m, bvh, zero, gs->mesh_root[m], tri_base[m], nodes, t, a);
        r = rd_upload(vk, NULL, &gs->blas_nodes, sizeof *nodes * gs->mesh_root[m], nodes,
                      sizeof *nodes * bvh->node_count, err, errlen);
        if (r == RD_VK_OK)
            r = rd_upload(vk, NULL, &gs->tris, sizeof *t * tri_base[m], t, sizeof *t * tris, err,
                          errlen);
        if (r == RD_VK_OK)
            r = rd_upload(vk, NULL, &gs->tri_attrs, sizeof *a * tri_base[m], a, sizeof *a * tris,
                          err, errlen);
        free(nodes);
        free(t);
        free(a);
        /* the GPU refits the tree this build made from now on */
        if (r == RD_VK_OK)
            r = rd_gpu_scene_deform_built(vk, gs, s, m, bvh, tri_base[m], err, errlen);
        gs->deform_rebuilds++;
        const pc_bvh_node *root = &bvh->nodes[0];
        const float b[6] = {root->bmin.x, root->bmin.y, root->bmin.z,
                            root->bmax.x, root->bmax.y, root->bmax.z};
        memcpy(&gs->mesh_bounds[6 * m], b, sizeof b);
        memcpy(&gs->mesh_local_bounds[6 * m], b, sizeof b);
        gs->mesh_revision[m] = s->meshes[m].deform->revision;
        if (bvh->depth > gs->max_blas_depth) gs->max_blas_depth = bvh->depth;
    }
    for (uint32_t k = 0; k < n; k++)
        rd_bvh_destroy(&bvhs[k]);
    free(bvhs);
    free(tri_base);
    return r;
}

rd_vk_result rd_gpu_scene_update_pose(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                      uint32_t *rebuilt, char *err, size_t errlen)
{
    double t0 = now_ms();
    uint32_t n = 0, *list = xcalloc(s->mesh_count, sizeof *list);
    uint32_t ng = 0, *gpu = xcalloc(s->mesh_count, sizeof *gpu);
    uint8_t *hit = xcalloc(s->mesh_count, 1), *degraded = xcalloc(s->mesh_count, 1);
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        if (!rd_gpu_scene_mesh_stale(gs, s, m)) continue;
        hit[m] = 1;
        if (rd_gpu_scene_deform_on_gpu(gs, m))
            gpu[ng++] = m;
        else
            list[n++] = m;
    }
    if (rebuilt) *rebuilt = n + ng;
    /* where their instances were: a new geometry revision logs it, then where they are */
    if (n + ng) gs->revision = gs->geometry_revision = ++last_revision;
    for (uint32_t i = 0; n + ng && gs->placed && i < gs->instance_capacity; i++) {
        if (gs->placed[i].info.y >= s->mesh_count || !hit[gs->placed[i].info.y]) continue;
        float lo[3], hi[3];
        placed_box(gs, i, lo, hi);
        log_box(gs, lo, hi);
    }
    rd_vk_result r = RD_VK_OK;
    if (ng) {
        r = rd_gpu_scene_deform_run(vk, gs, s, gpu, ng, degraded, err, errlen);
        if (r != RD_VK_OK && r != RD_VK_ERR_DEVICE_LOST && !vk->device_lost) {
            /* the GPU path failed (no pipeline, no memory): the CPU takes these meshes, now and
             * from now on */
            fprintf(stderr, "probecast: deforming meshes go to the CPU: %s\n", err);
            gs->deform_on_cpu = true;
            memset(degraded, 1, ng);
            r = RD_VK_OK;
        }
        for (uint32_t k = 0; r == RD_VK_OK && k < ng; k++) /* refitted too far: rebuilt now */
            if (degraded[k]) list[n++] = gpu[k];
    } else if (n) {
        gs->deform_ms = gs->refit_ms = 0;
    }
    if (r == RD_VK_OK && n) r = rebuild_meshes(vk, gs, s, list, n, err, errlen);
    if (n + ng) gs->deform_build_ms = now_ms() - t0;
    if (r == RD_VK_OK) r = update_instances(vk, NULL, gs, s, err, errlen);
    /* where the changed meshes' instances are now (update_instances logs only moved ones) */
    for (uint32_t i = 0; r == RD_VK_OK && n + ng && i < s->instance_count; i++) {
        if (!hit[s->instances[i].mesh] || i >= gs->instance_capacity) continue;
        float lo[3], hi[3];
        placed_box(gs, i, lo, hi);
        log_box(gs, lo, hi);
    }
    free(list);
    free(gpu);
    free(hit);
    free(degraded);
    return r;
}

/* rd_gpu_scene_update_lights; a new buffer's contents are staged into st when it is given */
static rd_vk_result update_lights(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs, const rd_scene *s,
                                  char *err, size_t errlen)
{
    uint32_t n = s->light_count;
    bool grow = n > gs->light_capacity || gs->lights.buffer == VK_NULL_HANDLE;
    if (grow) {
        /* frames in flight may read the old buffer */
        if (gs->lights.buffer != VK_NULL_HANDLE) rd_vk_wait_idle(vk);
        free(gs->lights_pending);
        gs->lights_pending = NULL;
        rd_buffer_destroy(vk, &gs->lights);
        uint32_t cap = n < 16 ? 16 : n;
        rd_vk_result r = rd_buffer_create(vk, &gs->lights, sizeof(pc_light) * cap, RD_MEMORY_DEVICE,
                                          err, errlen);
        if (r != RD_VK_OK) return r;
        gs->light_capacity = cap;
        gs->refs.lights = gs->lights.address;
        pc_light *placed = xcalloc(cap, sizeof *placed); /* the old ones are compared below */
        if (gs->placed_lights)
            memcpy(placed, gs->placed_lights, sizeof *placed * gs->refs.counts.y);
        free(gs->placed_lights);
        gs->placed_lights = placed;
    }
    pc_light *lights = xcalloc(n, sizeof *lights);
    for (uint32_t i = 0; i < n; i++) {
        const rd_light *l = &s->lights[i];
        float dir[3];
        const float down[3] = {0, 0, -1};
        rd_vec3_normalize(dir, l->direction, down);
        const float pos[3] = {l->position[0] - gs->origin_shift[0],
                              l->position[1] - gs->origin_shift[1],
                              l->position[2] - gs->origin_shift[2]};
        lights[i].position_range = v4(pos, l->range > 0 ? l->range : 0);
        lights[i].direction = v4(dir, 0);
        lights[i].radiance = (pc_vec4){l->color[0] * l->intensity, l->color[1] * l->intensity,
                                       l->color[2] * l->intensity, l->intensity};
        float outer = l->outer_cone, inner = l->inner_cone < outer ? l->inner_cone : outer;
        lights[i].spot = (pc_vec4){cosf(outer), cosf(inner), 0, 0};
        /* equal cones would make smoothstep undefined: keep a tiny soft edge */
        if (lights[i].spot.y - lights[i].spot.x < 1e-4f)
            lights[i].spot.y = lights[i].spot.x + 1e-4f;
        lights[i].info = (pc_uvec4){l->type == RD_LIGHT_SPOT          ? PC_LIGHT_SPOT
                                    : l->type == RD_LIGHT_DIRECTIONAL ? PC_LIGHT_DIRECTIONAL
                                                                      : PC_LIGHT_POINT,
                                    0, 0, 0};
    }
    for (uint32_t i = 0; i < n && i < PC_SHADOW_MAP_MAX_LIGHTS; i++) {
        /* a light new at this index (the count grew) always gets a revision */
        if (i >= gs->refs.counts.y || gs->light_revision[i] == 0 ||
            !same_placement(&lights[i], &gs->placed_lights[i]))
            gs->light_revision[i] = gs->revision = ++last_revision;
    }
    memcpy(gs->placed_lights, lights, sizeof *lights * n);
    if (n != gs->refs.counts.y) gs->revision = ++last_revision;
    rd_vk_result r = RD_VK_OK;
    gs->refs.counts.y = n;
    if (grow) { /* a new buffer: nothing reads it yet */
        if (n) r = rd_upload(vk, st, &gs->lights, 0, lights, sizeof *lights * n, err, errlen);
        free(lights);
        return r;
    }
    free(gs->lights_pending);
    gs->lights_pending = lights;
    gs->lights_pending_count = n;
    return r;
}

rd_vk_result rd_gpu_scene_update_lights(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s, char *err,
                                        size_t errlen)
{
    return update_lights(vk, NULL, gs, s, err, errlen);
}

void rd_gpu_scene_record_updates(rd_gpu_scene *gs, rd_cmd *cmd)
{
    if (!gs || !gs->lights_pending) return;
    /* vkCmdUpdateBuffer takes at most 65536 bytes, a multiple of 4 */
    const VkDeviceSize chunk = 65536 / sizeof(pc_light) * sizeof(pc_light);
    VkDeviceSize size = (VkDeviceSize)gs->lights_pending_count * sizeof(pc_light);
    for (VkDeviceSize off = 0; off < size; off += chunk)
        vkCmdUpdateBuffer(cmd->cb, gs->lights.buffer, off, size - off < chunk ? size - off : chunk,
                          (const char *)gs->lights_pending + off);
    rd_cmd_barrier(cmd);
    free(gs->lights_pending);
    gs->lights_pending = NULL;
    gs->lights_pending_count = 0;
}

/* rd_gpu_scene_upload, or with st its staging half (rd_gpu_scene_stage) */
static rd_vk_result scene_upload(rd_vk *vk, rd_staging *st, rd_gpu_scene *gs, const rd_scene *s,
                                 rd_gpu_scene_prep *prep, char *err, size_t errlen)
{
    memset(gs, 0, sizeof *gs);
    const char *deform = getenv("PROBECAST_DEFORM");
    gs->deform_on_cpu = deform && strcmp(deform, "cpu") == 0;
    for (int k = 0; k < 3; k++) {
        float c = 0.5f * (s->bounds_min[k] + s->bounds_max[k]);
        gs->origin_shift[k] = isfinite(c) ? c : 0.0f;
    }
    rd_vk_result r = upload_blas(vk, st, gs, prep, err, errlen);
    if (r == RD_VK_OK) r = update_instances(vk, st, gs, s, err, errlen);
    if (r == RD_VK_OK) r = rd_gpu_scene_upload_materials(vk, st, gs, s, err, errlen);
    if (r == RD_VK_OK) r = update_lights(vk, st, gs, s, err, errlen);
    if (r == RD_VK_OK && !st) r = rd_gpu_scene_lbvh_run(vk, gs, err, errlen);
    if (r != RD_VK_OK) {
        rd_gpu_scene_destroy(vk, gs);
        return r;
    }
    gs->refs = (pc_scene_refs){
        .tris = gs->tris.address,
        .tri_attrs = gs->tri_attrs.address,
        .blas_nodes = gs->blas_nodes.address,
        .tlas_nodes = gs->tlas_nodes.address,
        .tlas_index = gs->tlas_index.address,
        .instances = gs->instances.address,
        .materials = gs->materials.address,
        .textures = gs->textures.address,
        .texels = gs->texels.address,
        .lights = gs->lights.address,
        .counts = {s->instance_count, s->light_count, s->material_count, s->texture_count},
    };
    return RD_VK_OK;
}

rd_vk_result rd_gpu_scene_upload(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                 rd_gpu_scene_prep *prep, char *err, size_t errlen)
{
    return scene_upload(vk, NULL, gs, s, prep, err, errlen);
}

rd_vk_result rd_gpu_scene_stage(rd_vk *vk, rd_gpu_scene_staged *out, const rd_scene *s,
                                rd_gpu_scene_prep *prep, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    double t0 = now_ms();
    rd_vk_result r = scene_upload(vk, &out->copies, &out->gs, s, prep, err, errlen);
    if (r != RD_VK_OK) {
        rd_staging_release(vk, &out->copies);
        return r;
    }
    out->vk = vk;
    out->stage_ms = now_ms() - t0;
    return RD_VK_OK;
}

rd_vk_result rd_gpu_scene_commit(rd_gpu_scene_staged *st, rd_gpu_scene *gs, char *err,
                                 size_t errlen)
{
    double t0 = now_ms();
    rd_vk_result r = rd_staging_submit_wait(st->vk, &st->copies, err, errlen);
    if (r != RD_VK_OK) {
        rd_gpu_scene_staged_destroy(st);
        memset(gs, 0, sizeof *gs);
        return r;
    }
    rd_vk *vk = st->vk;
    *gs = st->gs;
    gs->upload_ms = st->stage_ms + (now_ms() - t0);
    memset(st, 0, sizeof *st);
    r = rd_gpu_scene_lbvh_run(vk, gs, err, errlen); /* the records are on the GPU now */
    if (r != RD_VK_OK) rd_gpu_scene_destroy(vk, gs);
    return r;
}

void rd_gpu_scene_staged_destroy(rd_gpu_scene_staged *st)
{
    if (!st->vk) return;
    rd_staging_release(st->vk, &st->copies);
    rd_gpu_scene_destroy(st->vk, &st->gs);
    memset(st, 0, sizeof *st);
}

rd_vk_result rd_gpu_scene_create(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s, char *err,
                                 size_t errlen)
{
    rd_gpu_scene_prep prep;
    rd_vk_result r = rd_gpu_scene_prepare_device(&prep, s, !vk->is_cpu, err, errlen);
    if (r != RD_VK_OK) {
        memset(gs, 0, sizeof *gs);
        return r;
    }
    r = rd_gpu_scene_upload(vk, gs, s, &prep, err, errlen);
    rd_gpu_scene_prep_destroy(&prep);
    return r;
}

void rd_gpu_scene_destroy(rd_vk *vk, rd_gpu_scene *gs)
{
    rd_gpu_scene_deform_destroy(vk, gs);
    rd_gpu_scene_lbvh_jobs_free(gs->lbvh_jobs);
    gs->lbvh_jobs = NULL;
    rd_buffer *bufs[] = {&gs->tris,       &gs->tri_attrs, &gs->blas_nodes, &gs->tlas_nodes,
                         &gs->tlas_index, &gs->instances, &gs->materials,  &gs->textures,
                         &gs->texels,     &gs->lights};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        rd_buffer_destroy(vk, bufs[i]);
    free(gs->mesh_root);
    free(gs->mesh_bounds);
    free(gs->mesh_origin);
    free(gs->mesh_local_bounds);
    free(gs->mesh_revision);
    gs->mesh_revision = NULL;
    free(gs->placed);
    gs->placed = NULL;
    free(gs->placed_lights);
    gs->placed_lights = NULL;
    free(gs->lights_pending);
    gs->mesh_root = NULL;
    gs->mesh_bounds = NULL;
    gs->mesh_origin = NULL;
    gs->mesh_local_bounds = NULL;
    gs->lights_pending = NULL;
    gs->lights_pending_count = 0;
    gs->instance_capacity = gs->light_capacity = 0;
    memset(&gs->refs, 0, sizeof gs->refs);
}

void rd_gpu_scene_mesh_world_bounds(const rd_gpu_scene *gs, uint32_t mesh, const float m[16],
                                    float lo[3], float hi[3])
{
    const float *b = &gs->mesh_bounds[6 * mesh];
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (int c = 0; c < 8; c++) { /* the 8 corners of the mesh's box, transformed */
        float p[3] = {b[(c & 1) ? 3 : 0], b[(c & 2) ? 4 : 1], b[(c & 4) ? 5 : 2]};
        for (int k = 0; k < 3; k++) {
            float w = m[k] * p[0] + m[4 + k] * p[1] + m[8 + k] * p[2] + m[12 + k];
            lo[k] = fminf(lo[k], w);
            hi[k] = fmaxf(hi[k], w);
        }
    }
}

void rd_gpu_scene_instance_bounds(const rd_gpu_scene *gs, const rd_scene *scene, uint32_t i,
                                  float lo[3], float hi[3])
{
    rd_gpu_scene_mesh_world_bounds(gs, scene->instances[i].mesh,
                                   scene->nodes[scene->instances[i].node].world, lo, hi);
}
