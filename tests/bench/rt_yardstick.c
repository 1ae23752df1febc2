/* rt_yardstick.c: probecast_rtbench, our ray traversal stated as a ratio of the driver's own
 * ray tracer on the same GPU, scene and rays (a benchmark program, not a test).
 *
 * The scene loads exactly as `probecast render` loads it (builtin:NAME[:ARG] or a glTF file).
 * Ours: the renderer's BVHs (rd_gpu_scene_create) traced by shaders/trace.glsl
 * (tests/bench/shaders/rtb_trace.comp). The driver's: a BLAS per mesh and a TLAS over the same
 * instances through VK_KHR_acceleration_structure, traced by a VK_KHR_ray_tracing_pipeline
 * (rt_driver.c). Both trace the same ray buffers, written once by rtb_rays.comp with the
 * renderer's own functions: primary rays of the scene's default camera (camera_dir) and DDGI
 * probe rays of the renderer's probe grid (rd_world_configure_gi, then ddgi_probe_position and
 * ddgi_ray_dir of the first update's rotation). Closest hit, no culling, every triangle opaque.
 * Each trace is warmed up for 0.5 s, then timed REPEATS times with GPU timestamps; the median
 * is reported. Results are compared ray by ray: hit or miss alike and the distance within
 * T_TOL relative; more than MISMATCH_MAX disagreeing is an error (exit status 1).
 * Without VK_KHR ray tracing (lavapipe) it says "unsupported: <reason>", still measures ours,
 * and exits 0.
 * Wide and cwide: the same BVHs collapsed on the CPU (rt_wide.c) to 4-wide nodes (bvh_wide.c,
 * traced by tests/bench/shaders/rtb_trace_wide.comp) and to compressed 8-wide nodes after
 * Ylitie, Karras, Laine, HPG 2017 (bvh_cwide.c, 80-byte nodes with 8-bit child boxes, traced by
 * rtb_trace_cwide.comp), over the same triangles and instances: measurements of whether wider
 * or compressed nodes would pay in the product (ratios wide/ours and cwide/ours > 1). The
 * compressed nodes are traced twice: cwide sorts each node's hit children by distance and
 * pushes them one by one, cwide2 walks node groups in ray-octant order with no sort (the
 * paper's algorithm 1; rtb_trace_cwide.comp with RTB_CWIDE_GROUPS). Their hits are compared
 * with ours the same way, on every device; the node memory of all three is printed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "renderer/scene/camera.h"
#include "renderer/world.h"
#include "rt_driver.h"
#include "rt_wide.h"
#include "rtb_cwide_types.h"
#include "server/base/args.h"
/* after stdint.h: the generated headers declare uint32_t arrays */
#include "bench/rtb_rays_comp.spv.h"
#include "bench/rtb_trace_comp.spv.h"
#include "bench/rtb_trace_cwide2_comp.spv.h"
#include "bench/rtb_trace_cwide_comp.spv.h"
#include "bench/rtb_trace_wide_comp.spv.h"

#define REPEATS 9          /* timed traces per ray set (median reported) */
#define WARMUP_S 0.5       /* untimed traces first: a GPU at idle clocks reads 2-5x slow */
#define T_TOL 1e-3f        /* hit distances agree within this fraction of max(t, 1) */
#define MISMATCH_MAX 0.001 /* fraction of rays allowed to disagree */
#define MAX_RAY_SETS 8

typedef struct options {
    const char *scene, *csv, *device;
    unsigned width, height;
    unsigned probes[3];
    unsigned rays[MAX_RAY_SETS];
    unsigned ray_sets;
    unsigned launch_width; /* driver launch rows; 0 = one row */
} options;

typedef struct bench {
    rd_vk *vk;
    rd_pipeline gen, trace, trace_wide, trace_cwide, trace_cwide2;
    rd_buffer globals, rays, hits_ours, hits_driver, hits_wide, hits_cwide, hits_cwide2;
    rd_timer timer;
    rtb_driver *driver; /* NULL when unsupported */
    rtb_wide_gpu *wide;
    const rd_gpu_scene *gs;
} bench;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(void)
{
    printf("usage: probecast_rtbench SCENE [OPTIONS]\n\n"
           "Traces the same rays through our BVH (shaders/trace.glsl), the driver's\n"
           "VK_KHR ray tracer and our BVHs collapsed to 4-wide (wide) and compressed\n"
           "8-wide nodes (cwide: sorted children, cwide2: octant-ordered node\n"
           "groups); prints times, Grays/s and ratios to ours.\n"
           "SCENE: a .gltf/.glb file or builtin:NAME[:ARG] (builtin:spheres:N,\n"
           "builtin:interior:M, ...), loaded as probecast render loads it.\n\n"
           "  --size WxH        primary rays of the scene's default camera (default 1920x1080)\n"
           "  --probes X,Y,Z    DDGI probe grid (default 32,8,32)\n"
           "  --rays N[,N...]   probe ray sets, rays per probe (default 64,256)\n"
           "  --csv FILE        append the rows to FILE (header when new)\n"
           "  --launch-width N  driver launches in rows of N rays (default: one row)\n"
           "  --device SEL      GPU index or name substring\n");
}

static bool parse(int argc, char **argv, options *o)
{
    *o = (options){
        .width = 1920, .height = 1080, .probes = {32, 8, 32}, .rays = {64, 256}, .ray_sets = 2};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            usage();
            exit(0);
        } else if (a[0] != '-') {
            o->scene = a;
            continue;
        }
        if (!v) {
            fprintf(stderr, "probecast_rtbench: %s needs a value\n", a);
            return false;
        }
        i++;
        if (strcmp(a, "--size") == 0) {
            if (sscanf(v, "%ux%u", &o->width, &o->height) != 2 || !o->width || !o->height ||
                o->width > 16384 || o->height > 16384) {
                fprintf(stderr, "probecast_rtbench: --size expects WxH\n");
                return false;
            }
        } else if (strcmp(a, "--probes") == 0) {
            if (sscanf(v, "%u,%u,%u", &o->probes[0], &o->probes[1], &o->probes[2]) != 3 ||
                !o->probes[0] || !o->probes[1] || !o->probes[2]) {
                fprintf(stderr, "probecast_rtbench: --probes expects X,Y,Z\n");
                return false;
            }
        } else if (strcmp(a, "--rays") == 0) {
            o->ray_sets = 0;
            for (const char *p = v; *p && o->ray_sets < MAX_RAY_SETS;) {
                char *end;
                unsigned long n = strtoul(p, &end, 10);
                if (end == p || n == 0 || n > 4096) {
                    fprintf(stderr, "probecast_rtbench: --rays expects N[,N...]\n");
                    return false;
                }
                o->rays[o->ray_sets++] = (unsigned)n;
                p = *end == ',' ? end + 1 : end;
            }
        } else if (strcmp(a, "--launch-width") == 0) {
            char *end;
            unsigned long n = strtoul(v, &end, 10);
            if (*end || n == 0 || n > UINT32_MAX) {
                fprintf(stderr, "probecast_rtbench: --launch-width expects a positive count\n");
                return false;
            }
            o->launch_width = (unsigned)n;
        } else if (strcmp(a, "--csv") == 0) {
            o->csv = v;
        } else if (strcmp(a, "--device") == 0) {
            o->device = v;
        } else {
            fprintf(stderr, "probecast_rtbench: unknown option %s\n", a);
            return false;
        }
    }
    if (!o->scene) {
        usage();
        return false;
    }
    return true;
}

/* Threads per row and groups of a 1D-indexed dispatch over n items. */
static void grid(uint32_t n, uint32_t *gx, uint32_t *gy)
{
    uint32_t groups = (n + PC_WG_1D - 1) / PC_WG_1D;
    *gx = groups < 65535 ? groups : 65535;
    *gy = *gx ? (groups + *gx - 1) / *gx : 0;
}

typedef enum tracer { TRACER_OURS, TRACER_DRIVER, TRACER_WIDE, TRACER_CWIDE, TRACER_CWIDE2 } tracer;

static void record(bench *b, rd_cmd *c, tracer which, uint32_t n)
{
    if (which == TRACER_DRIVER) {
        rtb_driver_record_trace(b->driver, c, b->rays.address, b->hits_driver.address, n);
    } else {
        const rd_pipeline *p = &b->trace;
        uint64_t hits = b->hits_ours.address, refs = 0;
        if (which == TRACER_WIDE)
            p = &b->trace_wide, hits = b->hits_wide.address, refs = b->wide->refs.address;
        if (which == TRACER_CWIDE)
            p = &b->trace_cwide, hits = b->hits_cwide.address, refs = b->wide->cwide.refs.address;
        if (which == TRACER_CWIDE2)
            p = &b->trace_cwide2, hits = b->hits_cwide2.address, refs = b->wide->cwide.refs.address;
        uint32_t gx, gy;
        grid(n, &gx, &gy);
        pc_push push = {.globals = b->globals.address,
                        .buf0 = b->rays.address,
                        .buf1 = hits,
                        .buf2 = refs,
                        .params = {n, 0, gx * PC_WG_1D, 0}};
        rd_cmd_dispatch(c, p, &push, gx, gy, 1);
    }
    rtb_barrier_all(c);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median GPU ms of one trace of the current ray buffer (0 when the queue has no timestamps). */
static rd_vk_result time_trace(bench *b, tracer which, uint32_t n, double *ms, char *err,
                               size_t errlen)
{
    rd_cmd c;
    rd_vk_result res = RD_VK_OK;
    double t0 = now_s();
    do {
        res = rd_cmd_begin(b->vk, &c, err, errlen);
        if (res != RD_VK_OK) return res;
        record(b, &c, which, n);
        res = rd_cmd_submit_wait(b->vk, &c, err, errlen);
    } while (res == RD_VK_OK && now_s() - t0 < WARMUP_S);
    if (res == RD_VK_OK) res = rd_cmd_begin(b->vk, &c, err, errlen);
    if (res != RD_VK_OK) return res;
    rd_timer_begin(&c, &b->timer);
    for (int r = 0; r < REPEATS; r++) {
        record(b, &c, which, n);
        rd_timer_mark(&c, &b->timer, "trace");
    }
    res = rd_cmd_submit_wait(b->vk, &c, err, errlen);
    if (res == RD_VK_OK) res = rd_timer_resolve(b->vk, &b->timer, err, errlen);
    if (res != RD_VK_OK) return res;
    double v[REPEATS];
    for (int r = 0; r < REPEATS; r++)
        v[r] = b->timer.valid ? b->timer.ms[r + 1] : 0;
    qsort(v, REPEATS, sizeof v[0], cmp_double);
    *ms = v[REPEATS / 2];
    return RD_VK_OK;
}

/* Writes n rays of the given kind (0 primary, 1 probes) from globals g. */
static rd_vk_result make_rays(bench *b, const pc_globals *g, uint32_t kind, uint32_t n, char *err,
                              size_t errlen)
{
    memcpy(b->globals.mapped, g, sizeof *g);
    rd_cmd c;
    rd_vk_result res = rd_cmd_begin(b->vk, &c, err, errlen);
    if (res != RD_VK_OK) return res;
    uint32_t gx, gy;
    grid(n, &gx, &gy);
    pc_push push = {.globals = b->globals.address,
                    .buf0 = b->rays.address,
                    .params = {n, kind, gx * PC_WG_1D, 0}};
    rd_cmd_dispatch(&c, &b->gen, &push, gx, gy, 1);
    rtb_barrier_all(&c);
    return rd_cmd_submit_wait(b->vk, &c, err, errlen);
}

typedef struct row {
    char set[64];
    uint32_t rays;
    double ours_ms, driver_ms, agree, hit_frac;
    double wide_ms, wide_agree; /* wide_agree: fraction of rays where wide matches ours */
    double cwide_ms, cwide_agree;
    double cwide2_ms, cwide2_agree;
} row;

/* Fraction of n rays whose hits agree: both miss, or both hit within T_TOL relative. */
static double agreement(const float *a, const float *d, uint32_t n)
{
    uint64_t same = 0;
    for (uint32_t i = 0; i < n; i++) {
        bool ha = a[i] >= 0, hd = d[i] >= 0;
        if (ha == hd && (!ha || fabsf(a[i] - d[i]) <= T_TOL * fmaxf(a[i], 1.0f))) same++;
    }
    return n ? (double)same / n : 1;
}

/* Traces the ray buffer with every tracer and compares the others' hits with ours. */
static rd_vk_result run_set(bench *b, uint32_t n, row *out, char *err, size_t errlen)
{
    out->rays = n;
    rd_vk_result res = time_trace(b, TRACER_OURS, n, &out->ours_ms, err, errlen);
    if (res == RD_VK_OK && b->driver)
        res = time_trace(b, TRACER_DRIVER, n, &out->driver_ms, err, errlen);
    if (res == RD_VK_OK) res = time_trace(b, TRACER_WIDE, n, &out->wide_ms, err, errlen);
    if (res == RD_VK_OK) res = time_trace(b, TRACER_CWIDE, n, &out->cwide_ms, err, errlen);
    if (res == RD_VK_OK) res = time_trace(b, TRACER_CWIDE2, n, &out->cwide2_ms, err, errlen);
    if (res != RD_VK_OK) return res;
    float *a = malloc((size_t)n * sizeof(float)), *d = malloc((size_t)n * sizeof(float));
    if (!a || !d) abort();
    res = rd_buffer_download(b->vk, &b->hits_ours, 0, a, (VkDeviceSize)n * 4, err, errlen);
    uint64_t hits = 0;
    for (uint32_t i = 0; i < n && res == RD_VK_OK; i++)
        hits += a[i] >= 0;
    out->hit_frac = n ? (double)hits / n : 0;
    if (res == RD_VK_OK && b->driver) {
        res = rd_buffer_download(b->vk, &b->hits_driver, 0, d, (VkDeviceSize)n * 4, err, errlen);
        if (res == RD_VK_OK) out->agree = agreement(a, d, n);
    }
    if (res == RD_VK_OK) {
        res = rd_buffer_download(b->vk, &b->hits_wide, 0, d, (VkDeviceSize)n * 4, err, errlen);
        if (res == RD_VK_OK) out->wide_agree = agreement(a, d, n);
    }
    if (res == RD_VK_OK) {
        res = rd_buffer_download(b->vk, &b->hits_cwide, 0, d, (VkDeviceSize)n * 4, err, errlen);
        if (res == RD_VK_OK) out->cwide_agree = agreement(a, d, n);
    }
    if (res == RD_VK_OK) {
        res = rd_buffer_download(b->vk, &b->hits_cwide2, 0, d, (VkDeviceSize)n * 4, err, errlen);
        if (res == RD_VK_OK) out->cwide2_agree = agreement(a, d, n);
    }
    free(a);
    free(d);
    return res;
}

static double grays(uint32_t rays, double ms)
{
    return ms > 0 ? rays / (ms * 1e6) : 0;
}

/* Speed of a tracer that took ms against ours: above 1 it traces faster (0 without
 * timestamps). wide/ours for the 4-wide nodes, cwide/ours and cwide2/ours for the compressed
 * 8-wide nodes. */
static double speedup(const row *r, double ms)
{
    return ms > 0 ? r->ours_ms / ms : 0;
}

static void print_row(FILE *f, bool csv, const char *scene, uint64_t tris, const row *r,
                      const rtb_driver *driver, const rtb_wide_gpu *wide)
{
    double og = grays(r->rays, r->ours_ms), wg = grays(r->rays, r->wide_ms);
    double cg = grays(r->rays, r->cwide_ms), c2g = grays(r->rays, r->cwide2_ms);
    double dg = driver ? grays(r->rays, r->driver_ms) : 0;
    if (csv) {
        fprintf(f,
                "%s,%llu,%s,%u,%.4f,%.4f,%.4f,%.4f,%.4f,%.6f,%.4f,%u,%.4f,%.4f,%.4f,%.6f,%llu,%llu,"
                "%.4f,%.4f,%.4f,%.6f,%llu,%.4f,%.4f,%.4f,%.6f\n",
                scene, (unsigned long long)tris, r->set, r->rays, r->ours_ms,
                driver ? r->driver_ms : 0, og, dg, dg > 0 ? og / dg : 0, driver ? r->agree : 0,
                r->hit_frac, driver ? driver->launch_width : 0, r->wide_ms, wg,
                speedup(r, r->wide_ms), r->wide_agree, (unsigned long long)wide->binary_node_bytes,
                (unsigned long long)wide->node_bytes, r->cwide_ms, cg, speedup(r, r->cwide_ms),
                r->cwide_agree, (unsigned long long)wide->cwide.node_bytes, r->cwide2_ms, c2g,
                speedup(r, r->cwide2_ms), r->cwide2_agree);
        return;
    }
    if (driver)
        fprintf(f, "%-24s %10llu  %-22s %9u %9.3f %9.3f %8.3f %8.3f %7.3f %8.4f%% %5.1f%%", scene,
                (unsigned long long)tris, r->set, r->rays, r->ours_ms, r->driver_ms, og, dg,
                dg > 0 ? og / dg : 0, 100 * r->agree, 100 * r->hit_frac);
    else
        fprintf(f, "%-24s %10llu  %-22s %9u %9.3f %9s %8.3f %8s %7s %9s %5.1f%%", scene,
                (unsigned long long)tris, r->set, r->rays, r->ours_ms, "-", og, "-", "-", "-",
                100 * r->hit_frac);
    fprintf(f,
            "  %9.3f %8.3f %7.3f %8.4f%%  %9.3f %8.3f %7.3f %8.4f%%  %9.3f %8.3f %7.3f %8.4f%%\n",
            r->wide_ms, wg, speedup(r, r->wide_ms), 100 * r->wide_agree, r->cwide_ms, cg,
            speedup(r, r->cwide_ms), 100 * r->cwide_agree, r->cwide2_ms, c2g,
            speedup(r, r->cwide2_ms), 100 * r->cwide2_agree);
}

static const char *CSV_HEADER = "scene,triangles,ray_set,rays,ours_ms,driver_ms,ours_grays,"
                                "driver_grays,ratio,agree,hit_fraction,driver_launch_width,"
                                "wide_ms,wide_grays,wide_ratio,wide_agree,ours_node_bytes,"
                                "wide_node_bytes,cwide_ms,cwide_grays,cwide_ratio,cwide_agree,"
                                "cwide_node_bytes,cwide2_ms,cwide2_grays,cwide2_ratio,"
                                "cwide2_agree\n";

/* Creates the device with VK_KHR ray tracing when it has it; *driver says which. */
static rd_vk_result create_device(rd_vk *vk, const options *o, bool *driver, char *err,
                                  size_t errlen)
{
    rtb_driver_features f;
    rd_vk_options vo = {.device = o->device};
    rtb_driver_device_options(&f, &vo);
    rd_vk_result res = rd_vk_create(vk, &vo, err, errlen);
    *driver = res == RD_VK_OK;
    if (res != RD_VK_ERR_UNSUPPORTED) return res;
    printf("unsupported: %s\n", err);
    rd_vk_options plain = {.device = o->device};
    return rd_vk_create(vk, &plain, err, errlen);
}

int main(int argc, char **argv)
{
    options o;
    if (!parse(argc, argv, &o)) return 2;
    rd_scene scene;
    if (!srv_arg_scene(o.scene, &scene)) return 1;
    char err[512] = "";
    rd_vk vk;
    bool has_driver = false;
    if (create_device(&vk, &o, &has_driver, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "probecast_rtbench: %s\n", err);
        rd_scene_destroy(&scene);
        return 1;
    }
    rd_vk_log_device(&vk, stdout);
    int status = 0;
    rd_gpu_scene gs = {0};
    rd_world world = {0};
    rtb_driver driver = {0};
    rtb_wide_gpu wide = {0};
    bench b = {.vk = &vk, .gs = &gs, .wide = &wide};
    uint64_t max_rays = (uint64_t)o.width * o.height;
    uint32_t probe_count = o.probes[0] * o.probes[1] * o.probes[2];
    for (unsigned i = 0; i < o.ray_sets; i++)
        if ((uint64_t)probe_count * o.rays[i] > max_rays)
            max_rays = (uint64_t)probe_count * o.rays[i];
    rd_vk_result res = max_rays > 0x7fffffffull / 32 ? RD_VK_ERR_UNSUPPORTED : RD_VK_OK;
    if (res != RD_VK_OK)
        snprintf(err, sizeof err, "%llu rays per set are too many", (unsigned long long)max_rays);
    if (res == RD_VK_OK) res = rd_gpu_scene_create(&vk, &gs, &scene, err, sizeof err);
    if (res == RD_VK_OK) {
        printf("scene %s: %llu triangles over %u instances (%u meshes)\n", o.scene,
               (unsigned long long)scene.tri_total, scene.instance_count, scene.mesh_count);
        printf("ours: BVH build %.1f ms (CPU), TLAS %.2f ms, %llu BLAS nodes\n", gs.blas_build_ms,
               gs.tlas_build_ms, (unsigned long long)gs.blas_node_count);
    }
    if (res == RD_VK_OK && has_driver) {
        res = rtb_driver_create(&vk, &driver, &scene, &gs, o.launch_width, err, sizeof err);
        if (res == RD_VK_OK) {
            b.driver = &driver;
            printf("driver: BLAS build %.2f ms, TLAS build %.3f ms (GPU), %.1f MiB, launch rows "
                   "of up to %u rays\n",
                   driver.blas_build_ms, driver.tlas_build_ms,
                   (double)driver.as_bytes / (1024.0 * 1024.0), driver.launch_width);
        }
    }
    if (res == RD_VK_OK) {
        res = rtb_wide_gpu_create(&vk, &wide, &gs, err, sizeof err);
        if (res == RD_VK_OK)
            printf("wide: 4-wide collapse %.1f ms (CPU), %u nodes, %u levels; node memory ours "
                   "%.2f MiB, wide %.2f MiB (%.2fx)\n",
                   wide.collapse_ms, wide.node_count, wide.depth,
                   (double)wide.binary_node_bytes / (1024.0 * 1024.0),
                   (double)wide.node_bytes / (1024.0 * 1024.0),
                   wide.binary_node_bytes ? (double)wide.node_bytes / wide.binary_node_bytes : 0);
        if (res == RD_VK_OK)
            printf("cwide: compressed 8-wide collapse %.1f ms (CPU), %u nodes of %zu bytes, %u "
                   "leaf entries of 4 bytes, %u levels; node memory %.2f MiB (%.2fx ours)\n",
                   wide.cwide.collapse_ms, wide.cwide.node_count, sizeof(rtb_cwide_node),
                   wide.cwide.leaf_count, wide.cwide.depth,
                   (double)wide.cwide.node_bytes / (1024.0 * 1024.0),
                   wide.binary_node_bytes ? (double)wide.cwide.node_bytes / wide.binary_node_bytes
                                          : 0);
    }
    if (res == RD_VK_OK)
        res = rd_pipeline_create(&vk, &b.gen, "rtb_rays", pc_spv_rtb_rays_comp,
                                 sizeof pc_spv_rtb_rays_comp, sizeof(pc_push), err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(&vk, &b.trace, "rtb_trace", pc_spv_rtb_trace_comp,
                                 sizeof pc_spv_rtb_trace_comp, sizeof(pc_push), err, sizeof err);
    if (res == RD_VK_OK)
        res =
            rd_pipeline_create(&vk, &b.trace_wide, "rtb_trace_wide", pc_spv_rtb_trace_wide_comp,
                               sizeof pc_spv_rtb_trace_wide_comp, sizeof(pc_push), err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(&vk, &b.trace_cwide, "rtb_trace_cwide",
                                 pc_spv_rtb_trace_cwide_comp, sizeof pc_spv_rtb_trace_cwide_comp,
                                 sizeof(pc_push), err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_pipeline_create(&vk, &b.trace_cwide2, "rtb_trace_cwide2",
                                 pc_spv_rtb_trace_cwide2_comp, sizeof pc_spv_rtb_trace_cwide2_comp,
                                 sizeof(pc_push), err, sizeof err);
    if (res == RD_VK_OK) res = rd_timer_create(&vk, &b.timer, err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_buffer_create(&vk, &b.globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err,
                               sizeof err);
    if (res == RD_VK_OK)
        res = rd_buffer_create(&vk, &b.rays, max_rays * 32, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_buffer_create(&vk, &b.hits_ours, max_rays * 4, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK)
        res =
            rd_buffer_create(&vk, &b.hits_driver, max_rays * 4, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_buffer_create(&vk, &b.hits_wide, max_rays * 4, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK)
        res = rd_buffer_create(&vk, &b.hits_cwide, max_rays * 4, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK)
        res =
            rd_buffer_create(&vk, &b.hits_cwide2, max_rays * 4, RD_MEMORY_DEVICE, err, sizeof err);
    if (res == RD_VK_OK) res = rd_world_create(&vk, &world, err, sizeof err);
    if (res == RD_VK_OK) rd_world_set_scene(&world, &gs);

    row rows[MAX_RAY_SETS + 1];
    unsigned nrows = 0;
    if (res == RD_VK_OK) { /* primary rays of the scene's default camera, as render shifts it */
        rd_view_camera cam;
        if (!rd_camera_for_scene(&scene, -1, &cam, err, sizeof err)) res = RD_VK_ERR_UNSUPPORTED;
        pc_globals g;
        memset(&g, 0, sizeof g);
        rd_world_fill_globals(&world, &g);
        for (int k = 0; k < 3; k++)
            cam.eye[k] -= gs.origin_shift[k];
        rd_camera_to_view(&cam, o.width, o.height, &g.view);
        g.view.size = (pc_uvec4){o.width, o.height, 0, 0};
        row *r = &rows[nrows++];
        memset(r, 0, sizeof *r);
        snprintf(r->set, sizeof r->set, "primary %ux%u", o.width, o.height);
        if (res == RD_VK_OK) res = make_rays(&b, &g, 0, o.width * o.height, err, sizeof err);
        if (res == RD_VK_OK) res = run_set(&b, o.width * o.height, r, err, sizeof err);
    }
    for (unsigned i = 0; i < o.ray_sets && res == RD_VK_OK; i++) { /* DDGI probe rays */
        rd_ddgi_settings gi = {.mode = PC_GI_DDGI,
                               .counts = {o.probes[0], o.probes[1], o.probes[2]},
                               .rays = o.rays[i]};
        res =
            rd_world_configure_gi(&world, scene.bounds_min, scene.bounds_max, &gi, err, sizeof err);
        if (res != RD_VK_OK) break;
        rd_ddgi_begin_update(&world.ddgi); /* the first update's ray rotation */
        pc_globals g;
        memset(&g, 0, sizeof g);
        rd_world_fill_globals(&world, &g);
        row *r = &rows[nrows++];
        memset(r, 0, sizeof *r);
        snprintf(r->set, sizeof r->set, "probes %ux%ux%u x%u", o.probes[0], o.probes[1],
                 o.probes[2], o.rays[i]);
        uint32_t n = probe_count * o.rays[i];
        res = make_rays(&b, &g, 1, n, err, sizeof err);
        if (res == RD_VK_OK) res = run_set(&b, n, r, err, sizeof err);
    }

    if (res == RD_VK_OK) {
        printf("\n%-24s %10s  %-22s %9s %9s %9s %8s %8s %7s %9s %6s  %9s %8s %7s %9s  %9s %8s "
               "%7s %9s  %9s %8s %7s %9s\n",
               "scene", "triangles", "ray set", "rays", "ours ms", "driver ms", "ours", "driver",
               "ratio", "agree", "hit", "wide ms", "wide", "wide/", "wide", "cwide ms", "cwide",
               "cwide/", "cwide", "cwide2 ms", "cwide2", "cwide2/", "cwide2");
        printf("%-24s %10s  %-22s %9s %9s %9s %8s %8s %7s %9s %6s  %9s %8s %7s %9s  %9s %8s %7s "
               "%9s  %9s %8s %7s %9s\n",
               "", "", "", "", "", "", "Grays/s", "Grays/s", "", "", "", "", "Grays/s", "ours",
               "agree", "", "Grays/s", "ours", "agree", "", "Grays/s", "ours", "agree");
        for (unsigned i = 0; i < nrows; i++)
            print_row(stdout, false, o.scene, scene.tri_total, &rows[i], b.driver, &wide);
        printf("\nnode bytes: ours %llu, wide %llu, cwide %llu\n",
               (unsigned long long)wide.binary_node_bytes, (unsigned long long)wide.node_bytes,
               (unsigned long long)wide.cwide.node_bytes);
        for (unsigned i = 0; i < nrows; i++) {
            double w = speedup(&rows[i], rows[i].wide_ms), c = speedup(&rows[i], rows[i].cwide_ms);
            double c2 = speedup(&rows[i], rows[i].cwide2_ms);
            printf("wide pays on %s: %s (wide/ours %.3f)\n", rows[i].set, w > 1 ? "yes" : "no", w);
            printf("cwide pays on %s: %s (cwide/ours %.3f)\n", rows[i].set, c > 1 ? "yes" : "no",
                   c);
            printf("cwide2 pays on %s: %s (cwide2/ours %.3f)\n", rows[i].set, c2 > 1 ? "yes" : "no",
                   c2);
        }
        for (unsigned i = 0; i < nrows; i++) {
            const char *name[3] = {"wide", "cwide", "cwide2"};
            double agree[3] = {rows[i].wide_agree, rows[i].cwide_agree, rows[i].cwide2_agree};
            for (int k = 0; k < 3; k++) {
                if (1 - agree[k] > MISMATCH_MAX) {
                    fprintf(stderr,
                            "probecast_rtbench: error: %s: %.4f%% of %s hits disagree with ours "
                            "(over %.2f%%)\n",
                            rows[i].set, 100 * (1 - agree[k]), name[k], 100 * MISMATCH_MAX);
                    status = 1;
                }
            }
        }
        for (unsigned i = 0; i < nrows && b.driver; i++) {
            if (1 - rows[i].agree > MISMATCH_MAX) {
                fprintf(stderr,
                        "probecast_rtbench: error: %s: %.4f%% of rays disagree (over %.2f%%)\n",
                        rows[i].set, 100 * (1 - rows[i].agree), 100 * MISMATCH_MAX);
                status = 1;
            }
        }
        if (o.csv) {
            FILE *probe = fopen(o.csv, "r");
            bool fresh = probe == NULL;
            if (probe) fclose(probe);
            FILE *f = fopen(o.csv, "a");
            if (!f) {
                fprintf(stderr, "probecast_rtbench: cannot write %s\n", o.csv);
                status = 1;
            } else {
                if (fresh) fputs(CSV_HEADER, f);
                for (unsigned i = 0; i < nrows; i++)
                    print_row(f, true, o.scene, scene.tri_total, &rows[i], b.driver, &wide);
                fclose(f);
            }
        }
    } else {
        fprintf(stderr, "probecast_rtbench: %s\n", err);
        status = 1;
    }
    rd_vk_wait_idle(&vk);
    if (rd_vk_validation_messages(&vk) > 0) { /* with PROBECAST_VALIDATION=1 (the ctest) */
        fprintf(stderr, "probecast_rtbench: %u validation messages\n",
                rd_vk_validation_messages(&vk));
        status = 1;
    }
    rd_world_destroy(&world);
    rd_buffer_destroy(&vk, &b.hits_cwide2);
    rd_buffer_destroy(&vk, &b.hits_cwide);
    rd_buffer_destroy(&vk, &b.hits_wide);
    rd_buffer_destroy(&vk, &b.hits_driver);
    rd_buffer_destroy(&vk, &b.hits_ours);
    rd_buffer_destroy(&vk, &b.rays);
    rd_buffer_destroy(&vk, &b.globals);
    rd_timer_destroy(&vk, &b.timer);
    rd_pipeline_destroy(&vk, &b.trace_cwide2);
    rd_pipeline_destroy(&vk, &b.trace_cwide);
    rd_pipeline_destroy(&vk, &b.trace_wide);
    rd_pipeline_destroy(&vk, &b.trace);
    rd_pipeline_destroy(&vk, &b.gen);
    rtb_driver_destroy(&driver);
    rtb_wide_gpu_destroy(&vk, &wide);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_vk_destroy(&vk);
    rd_scene_destroy(&scene);
    return status;
}
