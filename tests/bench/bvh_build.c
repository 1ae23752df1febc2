/* probecast_bvhbench: BLAS build time of the reference single-threaded builder
 * (rd_bvh_build_reference) against the renderer's builder (rd_bvh_build_triangles on one mesh,
 * and rd_bvh_build_many over the scene's meshes as rd_gpu_scene_prepare calls it) at several
 * thread counts, on the builtin:spheres benchmark scene (renderer/builtin/procedural.c) of 1, 4 and
 * 8 M triangles. Prints a table and writes it as CSV. A benchmark, not a test: nothing is
 * asserted about time; it exits non-zero only when a build fails or the new builder's output
 * differs between thread counts.
 *
 * Columns: triangles; builder (reference: boxes + rd_bvh_build_reference on one thread, as
 * rd_bvh_build_triangles did before; one-mesh: every triangle in one BVH; per-mesh: one BVH
 * per mesh of the scene, about 1 M triangles each, built together); threads; seconds (wall, median
 * of --runs); cpu_s (CPU time of all threads, median: on a shared machine the single-thread
 * figure that load does not inflate); M triangles/s; SAH cost (rd_bvh_sah_cost; per-mesh:
 * triangle-weighted mean); nodes; speedup over the reference at that size.
 *
 *   probecast_bvhbench [--sizes 1000000,4000000,8000000] [--threads 1,2,16] [--runs 3]
 *                      [--no-reference] [--machine NAME] [--csv out.csv]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "renderer/accel/bvh.h"
#include "tests/renderer/bvh_build_ref.h"
#include "renderer/builtin/procedural.h"
#include "renderer/accel/task_pool.h"

#define MAX_LIST 16

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int parse_list(const char *s, uint64_t *out)
{
    int n = 0;
    while (*s && n < MAX_LIST) {
        char *end;
        unsigned long long v = strtoull(s, &end, 10);
        if (end == s || v == 0) return -1;
        out[n++] = v;
        s = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') return -1;
    }
    return n;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The spheres scene's triangles, all meshes back to back; meshes[] point into them. */
typedef struct soup {
    float *pos;
    uint32_t tris;
    rd_bvh_mesh meshes[256];
    uint32_t mesh_count;
} soup;

static bool make_soup(uint64_t min_tris, soup *s)
{
    char name[64], err[256];
    snprintf(name, sizeof name, "spheres:%llu", (unsigned long long)min_tris);
    rd_scene sc;
    if (!rd_procedural_build(name, &sc, err, sizeof err)) {
        fprintf(stderr, "probecast_bvhbench: %s\n", err);
        return false;
    }
    uint64_t total = 0;
    for (uint32_t m = 0; m < sc.mesh_count; m++)
        total += sc.meshes[m].tri_count;
    memset(s, 0, sizeof *s);
    s->pos = malloc(total * 9 * sizeof(float));
    if (!s->pos || sc.mesh_count > 256) {
        rd_scene_destroy(&sc);
        return false;
    }
    for (uint32_t m = 0; m < sc.mesh_count; m++) {
        const rd_mesh *mesh = &sc.meshes[m];
        memcpy(s->pos + 9 * (size_t)s->tris, mesh->positions,
               (size_t)mesh->tri_count * 9 * sizeof(float));
        s->meshes[m] = (rd_bvh_mesh){s->pos + 9 * (size_t)s->tris, mesh->tri_count};
        s->tris += mesh->tri_count;
    }
    s->mesh_count = sc.mesh_count;
    rd_scene_destroy(&sc);
    return true;
}

typedef struct result {
    double seconds, cpu;
    double sah;
    uint64_t nodes;
    bool ok;
} result;

enum { REFERENCE, ONE_MESH, PER_MESH };
static const char *builder_name[] = {"reference", "one-mesh", "per-mesh"};

static bool same_bvh(const rd_bvh *a, const rd_bvh *b)
{
    return a->node_count == b->node_count && a->prim_count == b->prim_count &&
           !memcmp(a->nodes, b->nodes, a->node_count * sizeof *a->nodes) &&
           !memcmp(a->prim_index, b->prim_index, a->prim_count * sizeof *a->prim_index);
}

/* One build; keep (when non-NULL) receives the BVHs for the determinism check. */
static result run_once(const soup *s, int builder, uint32_t threads, rd_bvh *keep)
{
    result r = {0};
    rd_bvh bvh[256];
    uint32_t count = builder == PER_MESH ? s->mesh_count : 1;
    rd_bvh_options opt = {.threads = threads};
    double t0 = now_s(), c0 = cpu_s();
    if (builder == REFERENCE) {
        float *lo = malloc((size_t)s->tris * 6 * sizeof(float));
        if (!lo) return r;
        rd_bvh_triangle_boxes(s->pos, s->tris, lo, lo + 3 * (size_t)s->tris);
        r.ok = rd_bvh_build_reference(&bvh[0], lo, lo + 3 * (size_t)s->tris, s->tris, &opt);
        free(lo);
    } else if (builder == ONE_MESH) {
        r.ok = rd_bvh_build_triangles(&bvh[0], s->pos, s->tris, &opt);
    } else {
        r.ok = rd_bvh_build_many(bvh, s->meshes, s->mesh_count, &opt);
    }
    r.seconds = now_s() - t0;
    r.cpu = cpu_s() - c0;
    if (!r.ok) return r;
    for (uint32_t m = 0; m < count; m++) {
        r.sah += rd_bvh_sah_cost(&bvh[m]) * bvh[m].prim_count / s->tris;
        r.nodes += bvh[m].node_count;
        if (keep)
            keep[m] = bvh[m];
        else
            rd_bvh_destroy(&bvh[m]);
    }
    return r;
}

int main(int argc, char **argv)
{
    uint64_t sizes[MAX_LIST] = {1000000, 4000000, 8000000}, threads[MAX_LIST] = {1, 2, 16};
    int nsizes = 3, nthreads = 3, runs = 3;
    bool reference = true;
    const char *csv = NULL, *machine = "unnamed machine";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--no-reference")) {
            reference = false;
            continue;
        }
        if (!v) {
            fprintf(stderr, "probecast_bvhbench: %s needs a value (see the top of bvh_build.c)\n",
                    a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--sizes"))
            nsizes = parse_list(v, sizes);
        else if (!strcmp(a, "--threads"))
            nthreads = parse_list(v, threads);
        else if (!strcmp(a, "--runs"))
            runs = atoi(v);
        else if (!strcmp(a, "--csv"))
            csv = v;
        else if (!strcmp(a, "--machine"))
            machine = v;
        else {
            fprintf(stderr, "probecast_bvhbench: unknown option %s\n", a);
            return 2;
        }
        if (nsizes <= 0 || nthreads <= 0 || runs <= 0 || runs > 99) {
            fprintf(stderr, "probecast_bvhbench: bad value for %s: %s\n", a, v);
            return 2;
        }
    }
    FILE *out = csv ? fopen(csv, "w") : NULL;
    if (csv && !out) {
        perror(csv);
        return 1;
    }
    if (out)
        fprintf(out, "machine,triangles,meshes,builder,threads,seconds,cpu_seconds,mtris_per_s,sah_"
                     "cost,nodes,"
                     "speedup\n");
    printf("probecast_bvhbench on %s (%u online cores), median of %d runs\n", machine,
           rd_online_cores(), runs);
    printf("%10s %6s %-9s %7s %9s %9s %9s %9s %10s %8s\n", "triangles", "meshes", "builder",
           "threads", "seconds", "cpu_s", "Mtris/s", "SAH", "nodes", "speedup");
    int status = 0;
    for (int si = 0; si < nsizes; si++) {
        soup s;
        if (!make_soup(sizes[si], &s)) return 1;
        double ref_seconds = 0;
        static rd_bvh first[3][256];
        bool have_first[3] = {false, false, false};
        for (int builder = reference ? REFERENCE : ONE_MESH; builder <= PER_MESH; builder++) {
            for (int ti = 0; ti < (builder == REFERENCE ? 1 : nthreads); ti++) {
                uint32_t t = builder == REFERENCE ? 1 : (uint32_t)threads[ti];
                double secs[99], cpus[99];
                result r = {0};
                for (int k = 0; k < runs; k++) {
                    bool keep = !have_first[builder] && k == 0 && builder != REFERENCE;
                    rd_bvh got[256];
                    r = run_once(&s, builder, t, keep ? first[builder] : (k == 0 ? got : NULL));
                    if (!r.ok) {
                        fprintf(stderr, "probecast_bvhbench: build failed (out of memory)\n");
                        return 1;
                    }
                    secs[k] = r.seconds;
                    cpus[k] = r.cpu;
                    if (keep) {
                        have_first[builder] = true;
                    } else if (k == 0 && builder != REFERENCE) {
                        /* the same output at every thread count */
                        uint32_t n = builder == PER_MESH ? s.mesh_count : 1;
                        for (uint32_t m = 0; m < n; m++) {
                            if (!same_bvh(&first[builder][m], &got[m])) {
                                fprintf(stderr,
                                        "probecast_bvhbench: %s output differs at %u threads\n",
                                        builder_name[builder], t);
                                status = 1;
                            }
                            rd_bvh_destroy(&got[m]);
                        }
                    } else if (k == 0) {
                        rd_bvh_destroy(&got[0]);
                    }
                }
                qsort(secs, (size_t)runs, sizeof *secs, cmp_double);
                qsort(cpus, (size_t)runs, sizeof *cpus, cmp_double);
                double med = secs[runs / 2], cpu_med = cpus[runs / 2];
                if (builder == REFERENCE) ref_seconds = med;
                uint32_t meshes = builder == PER_MESH ? s.mesh_count : 1;
                char speed[32] = "";
                if (ref_seconds > 0) snprintf(speed, sizeof speed, "%.2f", ref_seconds / med);
                printf("%10u %6u %-9s %7u %9.3f %9.3f %9.2f %9.4f %10llu %8s\n", s.tris, meshes,
                       builder_name[builder], t, med, cpu_med, s.tris / med * 1e-6, r.sah,
                       (unsigned long long)r.nodes, speed);
                fflush(stdout);
                if (out)
                    fprintf(out, "\"%s\",%u,%u,%s,%u,%.4f,%.4f,%.3f,%.5f,%llu,%s\n", machine,
                            s.tris, meshes, builder_name[builder], t, med, cpu_med,
                            s.tris / med * 1e-6, r.sah, (unsigned long long)r.nodes, speed);
            }
        }
        for (int b = ONE_MESH; b <= PER_MESH; b++) {
            uint32_t n = b == PER_MESH ? s.mesh_count : 1;
            for (uint32_t m = 0; have_first[b] && m < n; m++)
                rd_bvh_destroy(&first[b][m]);
        }
        free(s.pos);
    }
    if (out) fclose(out);
    return status;
}
