/* lbvh_sort_check.c: the GPU LBVH's radix sort on lavapipe (test_gpu_lbvh runs it): the sort
 * on its own (rd_gpu_lbvh_record_sort) against a stable CPU sort of the same keys (1 to 70001
 * keys, random, few, equal and descending codes, rows of 65535, 3 and 1 groups), and the sorted
 * keys a whole build leaves in its scratch: its triangles ascending by (code, index). */
#include "lbvh_sort_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bvh_check.h"
#include "renderer/accel/gpu_lbvh.h"
#include "test_util.h"

static char err[512];

/* Keys of the sort (rd_gpu_lbvh_record_sort): x the payload, y the code. */
typedef struct sort_key {
    uint32_t x, y;
} sort_key;

static const sort_key *g_sort_in;
/* By code, then by position in g_sort_in: a stable order through qsort. */
static int cmp_stable(const void *pa, const void *pb)
{
    uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    uint32_t ya = g_sort_in[a].y, yb = g_sort_in[b].y;
    return ya != yb ? (ya < yb ? -1 : 1) : (a < b ? -1 : a > b);
}

/* Sorts n keys on the GPU with rd_gpu_lbvh_record_sort alone and checks the result equals a
 * stable CPU sort of the same keys by code (every key, payload and code, in its place). */
static void check_sort(rd_vk *vk, const rd_gpu_lbvh_builder *b, const char *what,
                       const sort_key *in, uint32_t n)
{
    size_t bytes = (size_t)n * sizeof *in;
    sort_key *out = malloc(bytes);
    uint32_t *order = malloc((size_t)n * sizeof *order);
    if (!out || !order) abort();
    rd_buffer keys = {0}, scratch = {0};
    rd_cmd c;
    bool ok = rd_buffer_create(vk, &keys, bytes, RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK &&
              rd_buffer_upload(vk, &keys, 0, in, bytes, err, sizeof err) == RD_VK_OK &&
              rd_buffer_create(vk, &scratch, rd_gpu_lbvh_sort_scratch_bytes(n), RD_MEMORY_DEVICE,
                               err, sizeof err) == RD_VK_OK &&
              rd_cmd_begin(vk, &c, err, sizeof err) == RD_VK_OK;
    if (ok) {
        rd_gpu_lbvh_record_sort(&c, b, keys.address, n, scratch.address);
        ok = rd_cmd_submit_wait(vk, &c, err, sizeof err) == RD_VK_OK &&
             rd_buffer_download(vk, &keys, 0, out, bytes, err, sizeof err) == RD_VK_OK;
    }
    CHECKF(ok, "%s: %s", what, err);
    for (uint32_t i = 0; i < n; i++)
        order[i] = i;
    g_sort_in = in;
    qsort(order, n, sizeof *order, cmp_stable);
    uint32_t wrong = 0, first = n;
    for (uint32_t i = 0; ok && i < n; i++)
        if (out[i].x != in[order[i]].x || out[i].y != in[order[i]].y) {
            wrong++;
            first = first < i ? first : i;
        }
    CHECKF(ok && wrong == 0, "%s: %u of %u keys out of place, the first at %u", what, wrong, n,
           first);
    fprintf(stderr, "sort %-36s %6u keys: %u out of place\n", what, n, wrong);
    rd_buffer_destroy(vk, &scratch);
    rd_buffer_destroy(vk, &keys);
    free(order);
    free(out);
}

/* The sort alone on keys whose payloads are not in order (so that stability shows): random
 * 32-bit codes, codes from 5 values (long runs of equal digits in every pass), all codes
 * equal, and codes in descending order; sizes around the 1024-key tiles and the 2048-word scan
 * blocks; then rows of 1 and 3 groups (the test hook) so that every dispatch has several rows. */
static void run_sort_tests(rd_vk *vk, const rd_gpu_lbvh_builder *b)
{
    static const uint32_t sizes[] = {1, 2, 127, 129, 1023, 1025, 5000, 70001};
    sort_key *in = malloc(70001 * sizeof *in);
    if (!in) abort();
    rd_gpu_lbvh_builder rows = *b;
    for (uint32_t hook = 0; hook < 3; hook++) {
        rows.row_groups = hook == 0 ? 0 : hook == 1 ? 3 : 1;
        for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
            uint32_t n = sizes[s];
            if (hook > 0 && n > 5000) continue; /* rows of 1 group: keep it quick */
            for (uint32_t kind = 0; kind < 4; kind++) {
                rng_seed(31 + 7 * s + kind);
                for (uint32_t i = 0; i < n; i++) {
                    uint32_t r = rng_u32();
                    in[i].x = rng_u32();
                    in[i].y = kind == 0   ? r
                              : kind == 1 ? (r % 5) * 0x01010101u + (r % 5 == 4 ? 0xff000000u : 0)
                              : kind == 2 ? 0x40000000u
                                          : ~i;
                }
                char what[96];
                static const char *kinds[] = {"random codes", "5 codes", "one code", "descending"};
                snprintf(what, sizeof what, "%s, rows of %u", kinds[kind],
                         hook == 0 ? 65535 : rows.row_groups);
                check_sort(vk, &rows, what, in, n);
            }
        }
    }
    free(in);
}

/* Builds pos with rd_gpu_lbvh_record on buffers of its own and checks the sorted keys the
 * build leaves in its scratch (shaders/lbvh.glsl: uvec2 at word 8): x a permutation of the
 * triangles, ascending by (code, triangle index) as a stable sort of lbvh_morton's keys (written
 * in triangle order) gives, equal codes in triangle order, non-finite triangles' code 1 << 30
 * (finite ones below), and prim_index (leaves of one triangle) the sorted triangle order. */
static void check_build_keys(rd_vk *vk, const rd_gpu_lbvh_builder *b, const char *what,
                             const float *pos, uint32_t n)
{
    size_t key_bytes = (size_t)n * sizeof(sort_key);
    sort_key *keys = malloc(key_bytes);
    uint32_t *prim = malloc((size_t)n * 4), *seen = calloc(n, sizeof *seen);
    if (!keys || !prim || !seen) abort();
    rd_buffer bp = {0}, nodes = {0}, bprim = {0}, scratch = {0};
    size_t pos_bytes = (size_t)n * 9 * sizeof(float);
    rd_cmd c;
    bool ok = rd_buffer_create(vk, &bp, pos_bytes, RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK &&
              rd_buffer_upload(vk, &bp, 0, pos, pos_bytes, err, sizeof err) == RD_VK_OK &&
              rd_buffer_create(vk, &nodes, rd_gpu_lbvh_node_count(n) * sizeof(pc_bvh_node),
                               RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK &&
              rd_buffer_create(vk, &bprim, (size_t)n * 4, RD_MEMORY_DEVICE, err, sizeof err) ==
                  RD_VK_OK &&
              rd_buffer_create(vk, &scratch, rd_gpu_lbvh_scratch_bytes(b, n), RD_MEMORY_DEVICE, err,
                               sizeof err) == RD_VK_OK &&
              rd_cmd_begin(vk, &c, err, sizeof err) == RD_VK_OK;
    if (ok) {
        rd_gpu_lbvh_record(&c, b, bp.address, n, 1, nodes.address, bprim.address, &scratch, NULL);
        ok = rd_cmd_submit_wait(vk, &c, err, sizeof err) == RD_VK_OK &&
             rd_buffer_download(vk, &scratch, 32, keys, key_bytes, err, sizeof err) == RD_VK_OK &&
             rd_buffer_download(vk, &bprim, 0, prim, (size_t)n * 4, err, sizeof err) == RD_VK_OK;
    }
    CHECKF(ok, "%s: %s", what, err);
    uint32_t bad = 0;
    for (uint32_t i = 0; ok && i < n; i++) {
        const sort_key *k = &keys[i];
        bool in_range = k->x < n && !seen[k->x]++;
        bool ascending =
            i == 0 || keys[i - 1].y < k->y || (keys[i - 1].y == k->y && keys[i - 1].x < k->x);
        bool code = in_range &&
                    (tri_finite(pos + 9 * (size_t)k->x) ? k->y < (1u << 30) : k->y == (1u << 30));
        if (!in_range || !ascending || !code || prim[i] != k->x) {
            if (bad++ < 3)
                fprintf(stderr, "%s: sorted key %u = (code %08x, triangle %u), prim_index %u\n",
                        what, i, k->y, k->x, prim[i]);
        }
    }
    CHECKF(ok && bad == 0, "%s: %u sorted keys wrong", what, bad);
    rd_buffer_destroy(vk, &scratch);
    rd_buffer_destroy(vk, &bprim);
    rd_buffer_destroy(vk, &nodes);
    rd_buffer_destroy(vk, &bp);
    free(seen);
    free(prim);
    free(keys);
}

/* The build's own keys (check_build_keys) for sizes that are not powers of two nor multiples
 * of the tiles, many equal centroids, non-finite triangles, and rows of 3 groups. */
static void run_build_key_tests(rd_vk *vk, const rd_gpu_lbvh_builder *b)
{
    static const uint32_t sizes[] = {1, 2, 127, 129, 5000, 70001};
    float *pos = tris_alloc(70001);
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        char what[64];
        rng_seed(41 + s);
        tri_soup(pos, sizes[s], 0.01f);
        snprintf(what, sizeof what, "build keys, soup %u", sizes[s]);
        check_build_keys(vk, b, what, pos, sizes[s]);
    }
    /* 3000 triangles on 7 centroids (runs of equal codes), every 50th non-finite */
    rng_seed(43);
    for (uint32_t i = 0; i < 3000; i++) {
        float c[3] = {0.1f * (float)(i % 7), 0.5f, -0.2f * (float)(i % 7)}, a[3], *v = pos + 9 * i;
        rng_unit(a);
        for (int k = 0; k < 3; k++) {
            v[k] = c[k] + a[k];
            v[3 + k] = c[k] - a[k];
            v[6 + k] = c[k];
        }
        if (i % 50 == 7) v[i % 9] = (i % 100 == 7) ? NAN : -INFINITY;
    }
    check_build_keys(vk, b, "build keys, 7 centroids", pos, 3000);
    rd_gpu_lbvh_builder rows = *b;
    rows.row_groups = 3;
    check_build_keys(vk, &rows, "build keys, 7 centroids, rows of 3", pos, 3000);
    tri_soup(pos, 5000, 0.02f);
    pos[9 * 4999 + 2] = NAN;
    check_build_keys(vk, &rows, "build keys, 5000, rows of 3", pos, 5000);
    free(pos);
}

void lbvh_sort_checks(rd_vk *vk, const rd_gpu_lbvh_builder *b)
{
    run_sort_tests(vk, b);
    run_build_key_tests(vk, b);
}
