/* bvh_check.h: helpers shared by the BVH tests; each one's contract is above it in
 * tests/renderer/bvh_check.c. */
#ifndef PC_TEST_BVH_CHECK_H
#define PC_TEST_BVH_CHECK_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/accel/bvh.h"

void rng_seed(uint64_t s);
uint32_t rng_u32(void);
float rng_f(void);
float rng_range(float a, float b);
void rng_unit(float d[3]);
float *tris_alloc(uint32_t n);
int64_t brute_closest(const float *pos, uint32_t n, const float o[3], const float d[3], float tmin,
                      float tmax, float *t_out);
bool tri_finite(const float *v);
bool box_empty(const pc_bvh_node *n);
bool box_contains(const pc_bvh_node *outer, const float lo[3], const float hi[3]);
bool slab_enter(const double lo[3], const double hi[3], const float o[3], const float d[3],
                double tmax, double *t0);
int check_structure(const char *what, const rd_bvh *bvh, const float *lo, const float *hi,
                    const bool *valid, uint32_t count, uint32_t max_leaf);
int check_triangles(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                    uint32_t max_leaf);
bool build_checked(const char *what, rd_bvh *bvh, const float *pos, uint32_t n,
                   const rd_bvh_options *opt);
uint32_t compare_rays(const char *what, const rd_bvh *bvh, const float *pos, uint32_t n,
                      const float *orgs, const float *dirs, uint32_t ray_count, float tmin,
                      float tmax);
void make_rays(float *orgs, float *dirs, uint32_t count, const float lo[3], const float hi[3],
               float margin, const float *pos, uint32_t n);
void random_tri(float *v, const float c[3], float size);
/* n random triangles of the given size, centred in [-1, 1]^3 (9 floats each). */
void tri_soup(float *pos, uint32_t n, float size);
void soup_case(const char *what, float *pos, uint32_t n, uint32_t ray_count,
               const rd_bvh_options *opt, float tmin, uint32_t min_hits);

#endif
