/* gpu_scene_deform.c: deforming meshes posed and refitted on the GPU in the scene's own buffers
 * (rd_gpu_scene_update_pose, gpu_scene.h). Per pose of a mesh whose BLAS the CPU built before,
 * one submission: shaders/deform.comp poses its vertices (gpu_deform.h), deform_tris.comp writes
 * its pc_tri / pc_tri_attr records at its place in gs->tris / gs->tri_attrs, and refit.comp
 * refits its nodes in place in gs->blas_nodes (gpu_refit.h), then its root box comes back for
 * the instance boxes of the top level. The CPU rebuild (gpu_scene.c) stays the first build of a
 * pose, the fallback, and the whole path under PROBECAST_DEFORM=cpu.
 *
 * When to rebuild on the CPU instead (decided by counts and costs, no clocks): the first pose
 * after the upload (the GPU needs the topology of a build it knows), every
 * RD_GPU_SCENE_REFIT_MAX-th pose after a build, and when the refitted tree has degraded: every
 * RD_GPU_SCENE_SAH_CHECK_EVERY-th refit its nodes come back and its SAH cost (rd_bvh_sah_cost)
 * is held against a fresh CPU build's of the same pose (from the CPU deformation's positions),
 * the ratio RD_GPU_REFIT_REBUILD_SAH_RATIO was measured against; past it, the mesh is rebuilt at
 * the pose where the verdict is applied (below), from that pose's positions (a second build: the
 * check's tree is not kept, which keeps one write path).
 * Holding the refitted cost against the cost the last build had is not enough: the cost is
 * normalised by the root's area, and a shape that changes (an arm bending from straight) changes
 * what the best tree costs (the arm of test_gpu_serve_skin: 1.69 straight, 2.35 bent, refitted or
 * fresh), so that proxy rebuilt every pose of a swinging arm. A check costs one CPU build and a
 * read-back of the mesh's nodes, once in RD_GPU_SCENE_SAH_CHECK_EVERY poses; the other poses
 * read back only the root box.
 *
 * The check's build runs off the render thread: done inline it stalled the pose 100-150 ms for a
 * 1 M-triangle character every RD_GPU_SCENE_SAH_CHECK_EVERY poses. At a check pose the render
 * thread takes the refitted tree's cost from the read-back (one pass over its nodes) and hands a
 * copy of the CPU-posed positions to a job on g->pool (one worker, owned here), which builds the
 * fresh tree and stores the verdict. Each later pose polls the job (rd_task_group_done); the
 * verdict is applied at the first pose of the mesh after the job finished, so a degraded tree
 * is rebuilt (at that pose, as before) one or more poses late. A mesh has at most one job in
 * flight (a check pose that finds one running skips its check); a CPU rebuild in the meantime
 * voids the verdict. The job reads only its own copies; destroy waits for it.
 * gs->deform_sah_checks counts finished checks. Still deterministic in what is decided (counts
 * and costs), not in when: rd_gpu_scene_deform_wait_checks waits for the jobs (tests). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_deform.h"
#include "renderer/accel/gpu_refit.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "renderer/accel/task_pool.h"
#include "shaders/deform_tris.spv.h"

#define RD_GPU_SCENE_REFIT_MAX 64u
#define RD_GPU_SCENE_SAH_CHECK_EVERY 8u

/* One mesh's SAH check off the render thread. The job (sah_check_run) owns positions while it
 * runs and writes only worse; the render thread touches the rest only while no job runs
 * (busy false, or rd_task_group_done). */
typedef struct sah_check {
    rd_task task; /* first member */
    rd_task_group group;
    bool busy;    /* submitted, its verdict not yet collected */
    bool voided;  /* the mesh was rebuilt on the CPU meanwhile: the verdict is dropped */
    bool rebuild; /* a collected verdict, applied at the mesh's next pose */
    double sah_refitted;
    float *positions; /* the posed triangles (9 floats each), the job's copy */
    uint32_t tri_count;
    bool worse; /* the job's verdict */
} sah_check;

typedef struct deform_mesh {
    bool ready; /* dm and refit made, for the BLAS the last CPU build wrote */
    rd_gpu_deform_mesh dm;
    rd_gpu_refit_blas refit;
    uint32_t refits;   /* poses refitted since that build */
    uint32_t tri_base; /* the mesh's first record in gs->tris */
    sah_check check;
} deform_mesh;

struct rd_gpu_scene_deform {
    bool pipelines; /* the three below made (on the first GPU pose) */
    rd_gpu_deformer deformer;
    rd_gpu_refitter refitter;
    rd_pipeline tris; /* deform_tris.comp */
    rd_timer timer;
    rd_buffer readback; /* root nodes, then the nodes of the meshes whose SAH is checked */
    uint32_t mesh_count;
    deform_mesh *meshes;
    rd_task_pool *pool; /* the SAH checks' (one worker; NULL: they run inline) */
};

/* Takes mesh m's finished check: counts it and keeps its verdict unless voided. */
static void collect(rd_gpu_scene *gs, sah_check *c)
{
    if (!c->busy || !rd_task_group_done(gs->deform->pool, &c->group)) return;
    c->busy = false;
    c->rebuild = c->worse && !c->voided;
    gs->deform_sah_checks++;
}

void rd_gpu_scene_deform_wait_checks(rd_gpu_scene *gs)
{
    rd_gpu_scene_deform *g = gs->deform;
    for (uint32_t m = 0; g && m < g->mesh_count; m++) {
        rd_task_wait(g->pool, &g->meshes[m].check.group);
        collect(gs, &g->meshes[m].check);
    }
}

void rd_gpu_scene_deform_destroy(rd_vk *vk, rd_gpu_scene *gs)
{
    rd_gpu_scene_deform *g = gs->deform;
    if (!g) return;
    rd_gpu_scene_deform_wait_checks(gs); /* no job may outlive what it belongs to */
    rd_task_pool_destroy(g->pool);
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        rd_gpu_deform_mesh_destroy(vk, &g->meshes[m].dm);
        rd_gpu_refit_blas_destroy(vk, &g->meshes[m].refit);
    }
    free(g->meshes);
    rd_buffer_destroy(vk, &g->readback);
    rd_timer_destroy(vk, &g->timer);
    rd_pipeline_destroy(vk, &g->tris);
    rd_gpu_refitter_destroy(vk, &g->refitter);
    rd_gpu_deformer_destroy(vk, &g->deformer);
    free(g);
    gs->deform = NULL;
}

bool rd_gpu_scene_deform_on_gpu(const rd_gpu_scene *gs, uint32_t m)
{
    const rd_gpu_scene_deform *g = gs->deform;
    return !gs->deform_on_cpu && g && m < g->mesh_count && g->meshes[m].ready &&
           g->meshes[m].refits + 1 < RD_GPU_SCENE_REFIT_MAX;
}

/* The joints of mesh m's last pose (rd_mesh_deform.posed: joint matrices, then weights). */
static uint32_t posed_joints(const rd_mesh_deform *d)
{
    size_t nt = d->target_count;
    return d->posed && d->posed_count >= nt ? (uint32_t)((d->posed_count - nt) / 16) : 0;
}

rd_vk_result rd_gpu_scene_deform_built(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s, uint32_t m,
                                       const rd_bvh *bvh, uint32_t tri_base, char *err,
                                       size_t errlen)
{
    if (gs->deform_on_cpu) return RD_VK_OK;
    if (!gs->deform) {
        gs->deform = xcalloc(1, sizeof *gs->deform);
        gs->deform->mesh_count = gs->mesh_count;
        gs->deform->meshes = xcalloc(gs->mesh_count, sizeof *gs->deform->meshes);
        gs->deform->pool = rd_task_pool_create(2); /* NULL: the checks run inline */
    }
    deform_mesh *dm = &gs->deform->meshes[m];
    /* a new tree: a check of the old one still running is void, one collected is stale */
    dm->check.voided = dm->check.busy;
    dm->check.rebuild = false;
    const rd_mesh_deform *d = s->meshes[m].deform;
    rd_vk_result r = RD_VK_OK;
    dm->ready = false;
    if (!dm->dm.vertex_data.buffer) {
        uint32_t jc = posed_joints(d), need = d->influences ? d->max_joint + 1 : 0;
        r = rd_gpu_deform_mesh_create(vk, &dm->dm, &s->meshes[m], jc > need ? jc : need, err,
                                      errlen);
    }
    /* the new tree's topology replaces the old one's (no submission reads it now) */
    rd_gpu_refit_blas_destroy(vk, &dm->refit);
    if (r == RD_VK_OK)
        r = rd_gpu_refit_blas_create_at(vk, &dm->refit, bvh, gs->blas_nodes.address,
                                        gs->mesh_root[m], tri_base, err, errlen);
    if (r != RD_VK_OK) { /* the mesh stays on the CPU path; a lost device is reported */
        rd_gpu_deform_mesh_destroy(vk, &dm->dm);
        rd_gpu_refit_blas_destroy(vk, &dm->refit);
        if (r == RD_VK_ERR_DEVICE_LOST || vk->device_lost) return r;
        fprintf(stderr, "probecast: deforming mesh %u is rebuilt on the CPU: %s\n", m, err);
        return RD_VK_OK;
    }
    dm->refits = 0;
    dm->tri_base = tri_base;
    dm->ready = true;
    return RD_VK_OK;
}

static const rd_pipeline_desc kPipelines[] = {
    RD_PIPELINE_DESC(rd_gpu_scene_deform, tris, "deform_tris", pc_spv_deform_tris,
                     (uint32_t)sizeof(pc_push)),
};

static rd_vk_result make_pipelines(rd_vk *vk, rd_gpu_scene_deform *g, char *err, size_t errlen)
{
    if (g->pipelines) return RD_VK_OK;
    rd_vk_result r = rd_gpu_deformer_create(vk, &g->deformer, err, errlen);
    if (r == RD_VK_OK) r = rd_gpu_refitter_create(vk, &g->refitter, err, errlen);
    if (r == RD_VK_OK) r = rd_pipelines_create(vk, g, kPipelines, 1, err, errlen);
    if (r == RD_VK_OK) r = rd_timer_create(vk, &g->timer, err, errlen);
    g->pipelines = r == RD_VK_OK;
    if (r != RD_VK_OK) { /* all idempotent: the next pose tries again from nothing */
        rd_timer_destroy(vk, &g->timer);
        rd_pipeline_destroy(vk, &g->tris);
        rd_gpu_refitter_destroy(vk, &g->refitter);
        rd_gpu_deformer_destroy(vk, &g->deformer);
    }
    return r;
}

/* Whether mesh dm's whole tree comes back this pose, for its SAH cost: a check pose, and no
 * check of the mesh in flight or waiting to be applied (then this one is skipped). */
static bool check_sah(const deform_mesh *dm)
{
    return (dm->refits + 1) % RD_GPU_SCENE_SAH_CHECK_EVERY == 0 && !dm->check.busy &&
           !dm->check.rebuild;
}

/* The check job: mesh's fresh CPU build over the posed positions, its SAH cost against the
 * refitted tree's; frees the positions. Reads and writes only c's own fields. */
static void sah_check_run(rd_task *t)
{
    sah_check *c = (sah_check *)t;
    rd_bvh fresh = {0};
    if (!rd_bvh_build_triangles(&fresh, c->positions, c->tri_count, NULL)) {
        fprintf(stderr, "probecast: out of memory building a BVH\n");
        abort();
    }
    c->worse = rd_gpu_refit_should_rebuild(c->sah_refitted, rd_bvh_sah_cost(&fresh));
    rd_bvh_destroy(&fresh);
    free(c->positions);
    c->positions = NULL;
}

/* Starts mesh m's check: its refitted tree (nodes, node_count of them, read back this pose)
 * against a fresh build of the CPU deformation's positions, on g->pool. */
static void start_check(rd_gpu_scene_deform *g, const rd_scene *s, uint32_t m,
                        const pc_bvh_node *nodes, uint32_t node_count)
{
    sah_check *c = &g->meshes[m].check;
    rd_bvh tree = {.nodes = (pc_bvh_node *)nodes, .node_count = node_count};
    size_t bytes = sizeof(float) * 9 * (size_t)s->meshes[m].tri_count;
    c->sah_refitted = rd_bvh_sah_cost(&tree);
    c->tri_count = s->meshes[m].tri_count;
    c->positions = xcalloc(bytes, 1);
    if (bytes) memcpy(c->positions, s->meshes[m].positions, bytes);
    c->worse = c->voided = false;
    c->busy = true;
    rd_task_submit(g->pool, &c->group, &c->task, sah_check_run);
}

/* Records mesh m's triangle records (its pose written) into c. */
static void record_tris(rd_cmd *c, rd_gpu_scene_deform *g, const rd_gpu_scene *gs, uint32_t m)
{
    const deform_mesh *dm = &g->meshes[m];
    uint32_t tris = dm->refit.prim_count;
    pc_push push = {
        .buf0 = gs->tris.address + (VkDeviceAddress)dm->tri_base * sizeof(pc_tri),
        .buf1 = gs->tri_attrs.address + (VkDeviceAddress)dm->tri_base * sizeof(pc_tri_attr),
        .buf2 = dm->dm.out.address,
        .params = {tris, (uint32_t)(dm->dm.out_normals / sizeof(float)),
                   dm->dm.has_tangents ? (uint32_t)(dm->dm.out_tangents / sizeof(float)) : 0, 0},
    };
    if (tris) rd_cmd_dispatch(c, &g->tris, &push, (tris + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
}

rd_vk_result rd_gpu_scene_deform_run(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                     const uint32_t *list, uint32_t n, uint8_t *rebuild, char *err,
                                     size_t errlen)
{
    rd_gpu_scene_deform *g = gs->deform;
    rd_vk_result r = make_pipelines(vk, g, err, errlen);
    if (r != RD_VK_OK) return r;
    for (uint32_t m = 0; m < g->mesh_count; m++) /* the checks that finished since */
        collect(gs, &g->meshes[m].check);
    /* what comes back: each mesh's root, then the whole trees checked this pose */
    size_t back = (size_t)n, *at = xcalloc(n, sizeof *at);
    for (uint32_t k = 0; k < n; k++) {
        const deform_mesh *dm = &g->meshes[list[k]];
        at[k] = check_sah(dm) ? back : 0;
        if (at[k]) back += dm->refit.node_count;
    }
    VkDeviceSize bytes = back * sizeof(pc_bvh_node);
    if (g->readback.size < bytes) {
        rd_buffer_destroy(vk, &g->readback);
        r = rd_buffer_create(vk, &g->readback, bytes, RD_MEMORY_READBACK, err, errlen);
        if (r != RD_VK_OK) {
            free(at);
            return r;
        }
    }
    for (uint32_t k = 0; k < n; k++) {
        const rd_mesh_deform *d = s->meshes[list[k]].deform;
        uint32_t jc = posed_joints(d);
        const float *pose = d->posed;
        rd_gpu_deform_set_pose(&g->meshes[list[k]].dm, d, pose ? pose + (size_t)jc * 16 : NULL,
                               d->target_count, jc ? pose : NULL, jc);
    }
    double t0 = now_ms();
    rd_cmd c;
    r = rd_cmd_begin(vk, &c, err, errlen);
    if (r != RD_VK_OK) {
        free(at);
        return r;
    }
    rd_timer_begin(&c, &g->timer);
    for (uint32_t k = 0; k < n; k++)
        rd_gpu_deform_record(&c, &g->deformer, &g->meshes[list[k]].dm);
    for (uint32_t k = 0; k < n; k++)
        record_tris(&c, g, gs, list[k]);
    rd_cmd_barrier(&c);
    rd_timer_mark(&c, &g->timer, "deform");
    for (uint32_t k = 0; k < n; k++) {
        const deform_mesh *dm = &g->meshes[list[k]];
        rd_gpu_refit_record(&c, &g->refitter, &dm->refit,
                            dm->dm.out.address + dm->dm.out_positions);
    }
    rd_timer_mark(&c, &g->timer, "refit");
    for (uint32_t k = 0; k < n; k++) {
        const deform_mesh *dm = &g->meshes[list[k]];
        VkBufferCopy root = {sizeof(pc_bvh_node) * (VkDeviceSize)gs->mesh_root[list[k]],
                             sizeof(pc_bvh_node) * (VkDeviceSize)k, sizeof(pc_bvh_node)};
        vkCmdCopyBuffer(c.cb, gs->blas_nodes.buffer, g->readback.buffer, 1, &root);
        if (!at[k]) continue;
        VkBufferCopy tree = {root.srcOffset, sizeof(pc_bvh_node) * (VkDeviceSize)at[k],
                             sizeof(pc_bvh_node) * (VkDeviceSize)dm->refit.node_count};
        vkCmdCopyBuffer(c.cb, gs->blas_nodes.buffer, g->readback.buffer, 1, &tree);
    }
    rd_cmd_barrier(&c); /* the copies, before the host reads them */
    r = rd_cmd_submit_wait(vk, &c, err, errlen);
    double wall = now_ms() - t0;
    if (r == RD_VK_OK) r = rd_timer_resolve(vk, &g->timer, err, errlen);
    if (r != RD_VK_OK) {
        free(at);
        return r;
    }
    /* GPU time of the pose and triangle writes, and of the refit; the submission's wall time
     * for the first where the device has no timestamps */
    gs->deform_ms = g->timer.valid ? g->timer.ms[1] : wall;
    gs->refit_ms = g->timer.valid ? g->timer.ms[2] : 0;
    if (!(g->readback.memory_flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)) {
        VkMappedMemoryRange range = {.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                                     .memory = g->readback.memory,
                                     .size = VK_WHOLE_SIZE};
        vkInvalidateMappedMemoryRanges(vk->device, 1, &range);
    }
    const pc_bvh_node *nodes = g->readback.mapped;
    for (uint32_t k = 0; k < n; k++) {
        uint32_t m = list[k];
        deform_mesh *dm = &g->meshes[m];
        const pc_bvh_node *root = &nodes[k];
        const float b[6] = {root->bmin.x, root->bmin.y, root->bmin.z,
                            root->bmax.x, root->bmax.y, root->bmax.z};
        memcpy(&gs->mesh_bounds[6 * m], b, sizeof b);
        memcpy(&gs->mesh_local_bounds[6 * m], b, sizeof b);
        gs->mesh_revision[m] = s->meshes[m].deform->revision;
        dm->refits++;
        gs->deform_refits++;
        /* a finished check's verdict now; else maybe a new check of this pose's tree */
        rebuild[k] = dm->check.rebuild;
        dm->check.rebuild = false;
        if (at[k]) start_check(g, s, m, &nodes[at[k]], dm->refit.node_count);
    }
    free(at);
    return RD_VK_OK;
}
