/* lbvh_sort_check.h: the GPU LBVH's radix sort checked on its own and inside a build (CHECKs
 * of test_util.h; lbvh_sort_check.c says what). */
#ifndef PC_LBVH_SORT_CHECK_H
#define PC_LBVH_SORT_CHECK_H

#include "renderer/accel/gpu_lbvh.h"
#include "renderer/vk/vk_context.h"

void lbvh_sort_checks(rd_vk *vk, const rd_gpu_lbvh_builder *b);

#endif
