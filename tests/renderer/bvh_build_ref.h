/* bvh_build_ref.h: the single-threaded recursive builder rd_bvh_build replaced, kept beside
 * the tests and the benchmark (probecast_bvhbench) as the reference the product's builder is
 * measured against; the renderer does not use it. Same contract as rd_bvh_build, threads
 * ignored. */
#ifndef TEST_BVH_BUILD_REF_H
#define TEST_BVH_BUILD_REF_H

#include "renderer/accel/bvh.h"

bool rd_bvh_build_reference(rd_bvh *bvh, const float *bmin, const float *bmax, uint32_t count,
                            const rd_bvh_options *opt);

#endif
