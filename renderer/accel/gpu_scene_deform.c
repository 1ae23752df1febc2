/* gpu_scene_deform.c: deforming meshes posed, refitted and rebuilt on the GPU in the scene's own
 * buffers (rd_gpu_scene_update_pose, gpu_scene.h). Per pose of a mesh whose BLAS was built
 * before, one submission: shaders/deform.comp poses its vertices (gpu_deform.h), deform_tris.comp
 * writes its pc_tri / pc_tri_attr records at its place in gs->tris / gs->tri_attrs, and
 * refit.comp refits its nodes in place in gs->blas_nodes (gpu_refit.h), then its root box comes
 * back for the instance boxes of the top level. The CPU build (gpu_scene.c) stays the first
 * pose's, the fallback, and the whole path under PROBECAST_DEFORM=cpu.
 *
 * When to rebuild instead of refit (decided by counts and costs, no clocks): the first pose
 * after the upload, on the CPU (the GPU needs the topology of a build it knows); then on the GPU
 * every RD_GPU_SCENE_REFIT_MAX-th pose after a build, and when the refitted tree has degraded:
 * every RD_GPU_SCENE_SAH_CHECK_EVERY-th refit its nodes come back and its SAH cost
 * (rd_bvh_sah_cost) is held against a fresh CPU build's of the same pose (from the CPU
 * deformation's positions), the ratio RD_GPU_REFIT_REBUILD_SAH_RATIO was measured against (for
 * a tree the LBVH built, times the ratio the first check after that build measured); past it,
 * the mesh is rebuilt at the pose where the verdict is applied (below), from its positions.
 * A GPU rebuild, in the pose's submission: the LBVH (gpu_lbvh.h) over the posed positions into
 * buffers of its own, then blas_place.comp puts its nodes at the mesh's place (its node and
 * record bases added) and gathers the triangle records in its new leaf order from the mesh's
 * source records (its original order, uploaded once), before deform_tris.comp writes the pose
 * into them; no refit (the LBVH's boxes are exact). After the submission the new tree's topology
 * is read back and its refit levels derived on the CPU (rare: a read-back is cheaper to keep
 * right than levels found on the GPU). A tree deeper than RD_BVH_MAX_DEPTH (the traversal's
 * stack), a mesh the LBVH cannot take, or no memory: the CPU rebuilds the mesh at that pose.
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
 * flight (a check pose that finds one running skips its check); a rebuild in the meantime
 * voids the verdict. The job reads only its own copies; destroy waits for it.
 * gs->deform_sah_checks counts finished checks. Still deterministic in what is decided (counts
 * and costs), not in when: rd_gpu_scene_deform_wait_checks waits for the jobs (tests). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_deform.h"
#include "renderer/accel/gpu_lbvh.h"
#include "renderer/accel/gpu_refit.h"
#include "renderer/accel/gpu_scene.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "renderer/accel/task_pool.h"
#include "shaders/deform_tris.spv.h"

#define RD_GPU_SCENE_REFIT_MAX 64u
#define RD_GPU_SCENE_SAH_CHECK_EVERY 8u
/* The SAH check of a tree the LBVH built holds it against a fresh CPU build times the ratio
 * the first check after that build measured (at least 1): an LBVH tree costs more than the
 * CPU builder's from the start, by how much depends on the mesh (1.11-1.17 on test_gpu_lbvh's
 * soups and spheres, 1.46 with all centroids equal). A fixed allowance of 1.2 let the Khronos
 * Fox (576 triangles) be rebuilt at nearly every check, 289 times in 2663 poses (H200,
 * tests/bench/results/h200/fox_served_stop43.txt): its fresh LBVH trees already passed it. */

/* One mesh's SAH check off the render thread. The job (sah_check_run) owns positions while it
 * runs and writes only worse; the render thread touches the rest only while no job runs
 * (busy false, or rd_task_group_done). */
typedef struct sah_check {
    rd_task task; /* first member */
    rd_task_group group;
    bool busy;                  /* submitted, its verdict not yet collected */
    bool voided;                /* the mesh was rebuilt meanwhile: the verdict is dropped */
    bool rebuild;               /* a collected verdict, applied at the mesh's next pose */
    double sah_refitted, slack; /* the refitted cost, and its allowance over a CPU build's (0:
                                   measure it, the first check after an LBVH build) */
    float *positions;           /* the posed triangles (9 floats each), the job's copy */
    uint32_t tri_count;
    bool worse;      /* the job's verdict */
    double measured; /* slack 0: the refitted over the fresh cost, the job's measure */
} sah_check;

typedef struct deform_mesh {
    bool ready;        /* dm, source and refit made, for the BLAS the last build wrote */
    bool lbvh;         /* that build was the GPU's (its SAH checks allow lbvh_slack) */
    double lbvh_slack; /* the first check's ratio to a CPU build (0: not measured yet) */
    rd_gpu_deform_mesh dm;
    rd_gpu_refit_blas refit;
    /* the mesh's triangle records in its original order (tri_count pc_tri, then as many
     * pc_tri_attr, as rd_gpu_scene_fill_mesh writes them), which a GPU rebuild gathers in its
     * new leaf order (blas_place.comp): 144 bytes a triangle, held while the mesh deforms */
    rd_buffer source;
    uint32_t refits;   /* poses refitted since that build */
    uint32_t tri_base; /* the mesh's first record in gs->tris */
    sah_check check;
} deform_mesh;

struct rd_gpu_scene_deform {
    bool pipelines; /* the pipelines and timer below made (on the first GPU pose) */
    rd_gpu_deformer deformer;
    rd_gpu_refitter refitter;
    rd_pipeline tris;  /* deform_tris.comp */
    rd_pipeline place; /* blas_place.comp */
    rd_gpu_lbvh_builder lbvh;
    rd_timer timer;
    rd_buffer readback; /* root nodes, then the nodes of the meshes whose SAH is checked */
    uint32_t mesh_count;
    deform_mesh *meshes;
    rd_task_pool *pool; /* the SAH checks' (one worker; NULL: they run inline) */
};

/* Takes mesh m's finished check: counts it and keeps its verdict unless voided. */
static void collect(rd_gpu_scene *gs, deform_mesh *dm)
{
    sah_check *c = &dm->check;
    if (!c->busy || !rd_task_group_done(gs->deform->pool, &c->group)) return;
    c->busy = false;
    c->rebuild = c->worse && !c->voided;
    if (c->slack == 0 && !c->voided) dm->lbvh_slack = c->measured > 1 ? c->measured : 1;
    gs->deform_sah_checks++;
}

void rd_gpu_scene_deform_wait_checks(rd_gpu_scene *gs)
{
    rd_gpu_scene_deform *g = gs->deform;
    for (uint32_t m = 0; g && m < g->mesh_count; m++) {
        rd_task_wait(g->pool, &g->meshes[m].check.group);
        collect(gs, &g->meshes[m]);
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
        rd_buffer_destroy(vk, &g->meshes[m].source);
    }
    free(g->meshes);
    rd_buffer_destroy(vk, &g->readback);
    rd_timer_destroy(vk, &g->timer);
    rd_pipeline_destroy(vk, &g->tris);
    rd_pipeline_destroy(vk, &g->place);
    rd_gpu_lbvh_builder_destroy(vk, &g->lbvh);
    rd_gpu_refitter_destroy(vk, &g->refitter);
    rd_gpu_deformer_destroy(vk, &g->deformer);
    free(g);
    gs->deform = NULL;
}

bool rd_gpu_scene_deform_on_gpu(const rd_gpu_scene *gs, uint32_t m)
{
    const rd_gpu_scene_deform *g = gs->deform;
    return !gs->deform_on_cpu && g && m < g->mesh_count && g->meshes[m].ready;
}

/* The joints of mesh m's last pose (rd_mesh_deform.posed: joint matrices, then weights). */
static uint32_t posed_joints(const rd_mesh_deform *d)
{
    size_t nt = d->target_count;
    return d->posed && d->posed_count >= nt ? (uint32_t)((d->posed_count - nt) / 16) : 0;
}

/* Uploads mesh m's source records (deform_mesh.source): rd_gpu_scene_fill_mesh over a tree of
 * no nodes whose leaf order is the original one. */
static rd_vk_result upload_source(rd_vk *vk, deform_mesh *dm, const rd_scene *s, uint32_t m,
                                  char *err, size_t errlen)
{
    uint32_t n = s->meshes[m].tri_count;
    uint32_t *order = xcalloc(n, sizeof *order);
    for (uint32_t i = 0; i < n; i++)
        order[i] = i;
    rd_bvh identity = {.prim_index = order, .prim_count = n};
    size_t tri_bytes = sizeof(pc_tri) * (size_t)n, bytes = tri_bytes + sizeof(pc_tri_attr) * n;
    char *rec = xcalloc(bytes, 1);
    const float zero[3] = {0, 0, 0}; /* deforming meshes have no local origin */
    rd_gpu_scene_fill_mesh(s, m, &identity, zero, 0, 0, NULL, (pc_tri *)rec,
                           (pc_tri_attr *)(rec + tri_bytes));
    rd_vk_result r = rd_buffer_create(vk, &dm->source, bytes, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK && n) r = rd_buffer_upload(vk, &dm->source, 0, rec, bytes, err, errlen);
    free(rec);
    free(order);
    return r;
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
    if (r == RD_VK_OK && !dm->source.buffer) r = upload_source(vk, dm, s, m, err, errlen);
    /* the new tree's topology replaces the old one's (no submission reads it now) */
    rd_gpu_refit_blas_destroy(vk, &dm->refit);
    if (r == RD_VK_OK)
        r = rd_gpu_refit_blas_create_at(vk, &dm->refit, bvh, gs->blas_nodes.address,
                                        gs->mesh_root[m], tri_base, err, errlen);
    if (r != RD_VK_OK) { /* the mesh stays on the CPU path; a lost device is reported */
        rd_gpu_deform_mesh_destroy(vk, &dm->dm);
        rd_gpu_refit_blas_destroy(vk, &dm->refit);
        rd_buffer_destroy(vk, &dm->source);
        if (r == RD_VK_ERR_DEVICE_LOST || vk->device_lost) return r;
        fprintf(stderr, "probecast: deforming mesh %u is rebuilt on the CPU: %s\n", m, err);
        return RD_VK_OK;
    }
    dm->refits = 0;
    dm->tri_base = tri_base;
    dm->lbvh = false;
    dm->ready = true;
    return RD_VK_OK;
}

static const rd_pipeline_desc kPipelines[] = {
    RD_PIPELINE_DESC(rd_gpu_scene_deform, tris, "deform_tris", pc_spv_deform_tris,
                     (uint32_t)sizeof(pc_push)),
};
#define PIPELINE_COUNT (sizeof kPipelines / sizeof kPipelines[0])

static rd_vk_result make_pipelines(rd_vk *vk, rd_gpu_scene_deform *g, char *err, size_t errlen)
{
    if (g->pipelines) return RD_VK_OK;
    rd_vk_result r = rd_gpu_deformer_create(vk, &g->deformer, err, errlen);
    if (r == RD_VK_OK) r = rd_gpu_refitter_create(vk, &g->refitter, err, errlen);
    if (r == RD_VK_OK) r = rd_pipelines_create(vk, g, kPipelines, PIPELINE_COUNT, err, errlen);
    if (r == RD_VK_OK) r = rd_gpu_scene_place_create(vk, &g->place, err, errlen);
    if (r == RD_VK_OK) r = rd_gpu_lbvh_builder_create(vk, &g->lbvh, err, errlen);
    /* rebuilds by the LBVH, or by PLOC where PROBECAST_BLAS_BUILD=ploc asks the GPU for it */
    if (r == RD_VK_OK && rd_blas_build_from_env() == RD_BLAS_BUILD_GPU_PLOC)
        g->lbvh.method = RD_GPU_BVH_PLOC;
    if (r == RD_VK_OK) r = rd_timer_create(vk, &g->timer, err, errlen);
    g->pipelines = r == RD_VK_OK;
    if (r != RD_VK_OK) { /* all idempotent: the next pose tries again from nothing */
        rd_timer_destroy(vk, &g->timer);
        rd_gpu_lbvh_builder_destroy(vk, &g->lbvh);
        rd_pipeline_destroy(vk, &g->place);
        rd_pipelines_destroy(vk, g, kPipelines, PIPELINE_COUNT);
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
    double fresh_cost = rd_bvh_sah_cost(&fresh);
    if (c->slack > 0) {
        c->worse = rd_gpu_refit_should_rebuild(c->sah_refitted / c->slack, fresh_cost);
    } else { /* the first check of an LBVH tree: its own ratio, no verdict */
        c->measured = fresh_cost > 0 ? c->sah_refitted / fresh_cost : 1;
        c->worse = false;
    }
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
    c->slack = g->meshes[m].lbvh ? g->meshes[m].lbvh_slack : 1.0;
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

/* Whether mesh dm's tree is rebuilt on the GPU this pose, instead of refitted: a collected
 * verdict of degradation (taken here), or RD_GPU_SCENE_REFIT_MAX poses since its last build. */
static bool rebuild_due(deform_mesh *dm)
{
    bool due = dm->check.rebuild || dm->refits + 1 >= RD_GPU_SCENE_REFIT_MAX;
    dm->check.rebuild = false;
    return due && dm->refit.prim_count > 0;
}

/* Records mesh m's LBVH build over its posed positions into b, then its placing in the scene's
 * buffers (blas_place.comp): the nodes at the mesh's place with its node and record bases added
 * (they fit: a deforming mesh's BLAS has 2 n slots, an LBVH at most 2 n - 1 nodes), the triangle
 * records gathered from its source records in the new leaf order. deform_tris.comp writes the
 * pose into those records after the caller's barrier. */
static void record_rebuild(rd_cmd *c, rd_gpu_scene_deform *g, const rd_gpu_scene *gs, uint32_t m,
                           const rd_gpu_scene_lbvh_build *b)
{
    const deform_mesh *dm = &g->meshes[m];
    rd_gpu_scene_record_lbvh_place(c, &g->lbvh, &g->place, gs, gs->mesh_root[m], dm->tri_base,
                                   dm->refit.prim_count, dm->dm.out.address + dm->dm.out_positions,
                                   dm->source.address, b);
}

/* After the submission: mesh m's GPU-built tree becomes the one its refits follow. Its topology
 * comes back (node count, nodes, prim_index: about 68 bytes a triangle, read once in
 * RD_GPU_SCENE_REFIT_MAX poses or at a degraded tree, which is rare enough to pay a read-back
 * for) and its refit levels are derived on the CPU (rd_gpu_refit_blas_create_at). *ok false:
 * the tree is deeper than the traversal's stack allows (RD_BVH_MAX_DEPTH; an LBVH may reach 64)
 * or not a whole tree, or no memory: the caller rebuilds the mesh on the CPU. Returns only a
 * lost device. */
static rd_vk_result adopt_rebuild(rd_vk *vk, rd_gpu_scene *gs, uint32_t m,
                                  const rd_gpu_scene_lbvh_build *b, bool *ok, char *err,
                                  size_t errlen)
{
    deform_mesh *dm = &gs->deform->meshes[m];
    uint32_t n = dm->refit.prim_count;
    rd_bvh t = {.prim_count = n};
    *ok = false;
    rd_vk_result r = rd_buffer_download(vk, &b->scratch, RD_GPU_LBVH_COUNT_OFFSET, &t.node_count, 4,
                                        err, errlen);
    if (r == RD_VK_OK && !(t.node_count >= 1 && t.node_count <= rd_gpu_lbvh_node_count(n))) {
        snprintf(err, errlen, "the GPU build of mesh %u has %u nodes", m, t.node_count);
        r = RD_VK_ERR_VULKAN;
    }
    if (r == RD_VK_OK) {
        t.nodes = xcalloc(t.node_count, sizeof *t.nodes);
        t.prim_index = xcalloc(n, sizeof *t.prim_index);
        r = rd_buffer_download(vk, &b->out, 0, t.nodes, sizeof *t.nodes * t.node_count, err,
                               errlen);
    }
    if (r == RD_VK_OK)
        r = rd_buffer_download(vk, &b->out, b->prim_at, t.prim_index, 4 * (size_t)n, err, errlen);
    if (r == RD_VK_OK) {
        rd_gpu_refit_blas_destroy(vk, &dm->refit); /* no submission reads it now */
        r = rd_gpu_refit_blas_create_at(vk, &dm->refit, &t, gs->blas_nodes.address,
                                        gs->mesh_root[m], dm->tri_base, err, errlen);
    }
    if (r == RD_VK_OK) {
        uint32_t depth = dm->refit.level_count - 1;
        *ok = dm->refit.level_start[dm->refit.level_count] == t.node_count &&
              depth <= RD_BVH_MAX_DEPTH;
        if (!*ok)
            snprintf(err, errlen, "the GPU build of mesh %u is %u deep or not whole", m, depth);
        else if (depth > gs->max_blas_depth)
            gs->max_blas_depth = depth;
    }
    rd_bvh_destroy(&t);
    if (r == RD_VK_ERR_DEVICE_LOST || vk->device_lost) return r;
    if (!*ok) fprintf(stderr, "probecast: mesh %u is rebuilt on the CPU: %s\n", m, err);
    return RD_VK_OK;
}

rd_vk_result rd_gpu_scene_deform_run(rd_vk *vk, rd_gpu_scene *gs, const rd_scene *s,
                                     const uint32_t *list, uint32_t n, uint8_t *rebuild, char *err,
                                     size_t errlen)
{
    rd_gpu_scene_deform *g = gs->deform;
    rd_vk_result r = make_pipelines(vk, g, err, errlen);
    if (r != RD_VK_OK) return r;
    for (uint32_t m = 0; m < g->mesh_count; m++) /* the checks that finished since */
        collect(gs, &g->meshes[m]);
    /* the meshes rebuilt on the GPU this pose (their LBVH's buffers made), the others refitted;
     * one that the LBVH cannot take goes to the CPU (rebuild[k]) */
    rd_gpu_scene_lbvh_build *builds = xcalloc(n, sizeof *builds);
    uint8_t *built = xcalloc(n, 1);
    for (uint32_t k = 0; k < n; k++) {
        deform_mesh *dm = &g->meshes[list[k]];
        rebuild[k] = 0;
        if (!rebuild_due(dm)) continue;
        uint32_t tris = dm->refit.prim_count;
        rd_vk_result br = RD_VK_ERR_VULKAN;
        if (rd_gpu_lbvh_node_count(tris) > blas_slots(&s->meshes[list[k]], 0)) /* never */
            snprintf(err, errlen, "an LBVH of %u triangles does not fit the BLAS's slots", tris);
        else
            br = rd_gpu_scene_lbvh_build_create(vk, &builds[k], &g->lbvh, tris, err, errlen);
        if (br == RD_VK_OK) {
            built[k] = 1;
        } else {
            if (vk->device_lost) break;
            fprintf(stderr, "probecast: mesh %u is rebuilt on the CPU: %s\n", list[k], err);
            rebuild[k] = 1;
        }
    }
    /* what comes back: each mesh's root, then the whole trees checked this pose */
    size_t back = (size_t)n, *at = xcalloc(n, sizeof *at);
    for (uint32_t k = 0; k < n; k++) {
        const deform_mesh *dm = &g->meshes[list[k]];
        at[k] = !built[k] && !rebuild[k] && check_sah(dm) ? back : 0;
        if (at[k]) back += dm->refit.node_count;
    }
    VkDeviceSize bytes = back * sizeof(pc_bvh_node);
    if (g->readback.size < bytes) {
        rd_buffer_destroy(vk, &g->readback);
        r = rd_buffer_create(vk, &g->readback, bytes, RD_MEMORY_READBACK, err, errlen);
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
    if (r == RD_VK_OK) r = rd_cmd_begin(vk, &c, err, errlen);
    if (r != RD_VK_OK) goto out;
    rd_timer_begin(&c, &g->timer);
    for (uint32_t k = 0; k < n; k++)
        rd_gpu_deform_record(&c, &g->deformer, &g->meshes[list[k]].dm);
    bool any = false; /* the GPU builds: counted in the deform time */
    for (uint32_t k = 0; k < n; k++)
        if (built[k]) record_rebuild(&c, g, gs, list[k], &builds[k]), any = true;
    if (any) rd_cmd_barrier(&c);
    for (uint32_t k = 0; k < n; k++)
        record_tris(&c, g, gs, list[k]);
    rd_cmd_barrier(&c);
    rd_timer_mark(&c, &g->timer, "deform");
    for (uint32_t k = 0; k < n; k++) {
        const deform_mesh *dm = &g->meshes[list[k]];
        if (!built[k])
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
    if (r != RD_VK_OK) goto out;
    /* GPU time of the pose and triangle writes (and GPU builds), and of the refit; the
     * submission's wall time for the first where the device has no timestamps */
    gs->deform_ms = g->timer.valid ? g->timer.ms[1] : wall;
    gs->refit_ms = g->timer.valid ? g->timer.ms[2] : 0;
    if (!(g->readback.memory_flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)) {
        VkMappedMemoryRange range = {.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                                     .memory = g->readback.memory,
                                     .size = VK_WHOLE_SIZE};
        vkInvalidateMappedMemoryRanges(vk->device, 1, &range);
    }
    const pc_bvh_node *nodes = g->readback.mapped;
    for (uint32_t k = 0; k < n && r == RD_VK_OK; k++) {
        uint32_t m = list[k];
        deform_mesh *dm = &g->meshes[m];
        const pc_bvh_node *root = &nodes[k];
        const float b[6] = {root->bmin.x, root->bmin.y, root->bmin.z,
                            root->bmax.x, root->bmax.y, root->bmax.z};
        memcpy(&gs->mesh_bounds[6 * m], b, sizeof b);
        memcpy(&gs->mesh_local_bounds[6 * m], b, sizeof b);
        gs->mesh_revision[m] = s->meshes[m].deform->revision;
        if (built[k]) { /* a new tree: a check of the old one still running is void */
            bool ok = false;
            r = adopt_rebuild(vk, gs, m, &builds[k], &ok, err, errlen);
            rebuild[k] = !ok;
            dm->check.voided = dm->check.busy;
            dm->refits = 0;
            dm->lbvh = true;
            dm->lbvh_slack = 0;
            gs->deform_gpu_rebuilds += ok;
            continue;
        }
        dm->refits++;
        gs->deform_refits++;
        if (at[k]) start_check(g, s, m, &nodes[at[k]], dm->refit.node_count);
    }
out:
    for (uint32_t k = 0; k < n; k++)
        rd_gpu_scene_lbvh_build_destroy(vk, &builds[k]);
    free(builds);
    free(built);
    free(at);
    return r;
}
