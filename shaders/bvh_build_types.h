/* bvh_build_types.h: the GPU BVH builder's constants, shared by C (renderer/accel/gpu_lbvh.c,
 * gpu_ploc.c, the tests) and GLSL (shaders/lbvh*.comp, ploc*.comp): the LBVH's scan, sort and leaf
 * collapse, PLOC's rounds and the layout of its scratch area (shaders/ploc.glsl). Split from
 * gpu_types.h, which holds the renderer's shared types. */
#ifndef PC_BVH_BUILD_TYPES_H
#define PC_BVH_BUILD_TYPES_H

#include "gpu_types.h"

/* The GPU LBVH's node renumbering (shaders/lbvh_scan.comp): words of its prefix sum that one
 * workgroup scans (a multiple of PC_WG_1D). */
#define PC_LBVH_SCAN_BLOCK 2048u
/* The GPU LBVH's leaf collapse weighs a leaf's SAH cost by this (shaders/lbvh_boxes.comp says
 * why: traversal measured faster than at 1). */
#define PC_LBVH_LEAF_WEIGHT 0.75
/* The GPU LBVH's radix sort (shaders/lbvh_sort.comp): passes of 8-bit digits over the 31-bit
 * keys, tiles of PC_LBVH_SORT_TILE keys a workgroup (16 a thread), the (digit, tile) counts
 * scanned in blocks of PC_LBVH_SORT_SCAN_BLOCK words (32 a thread). */
#define PC_LBVH_SORT_PASSES 4u
#define PC_LBVH_SORT_DIGITS 256u
#define PC_LBVH_SORT_ROUNDS 16u
#define PC_LBVH_SORT_TILE (PC_WG_1D * PC_LBVH_SORT_ROUNDS)
#define PC_LBVH_SORT_SCAN_PER_THREAD 32u
#define PC_LBVH_SORT_SCAN_BLOCK (PC_WG_1D * PC_LBVH_SORT_SCAN_PER_THREAD)
/* The GPU PLOC builder (shaders/ploc_*.comp, renderer/accel/gpu_ploc.c): clusters search their
 * nearest neighbour among PC_PLOC_RADIUS places either side (Meister and Bittner 2018's default);
 * PC_PLOC_ROUNDS rounds of clustering (39-58 measured on meshes), then at most
 * PC_PLOC_FORCED_ROUNDS rounds that pair neighbours (2i, 2i + 1) whatever their boxes, so that
 * every build ends (count halves each round: 2^24 -> 1 in 24); a round's merges and keeps are
 * counted in blocks of PC_PLOC_BLOCK places (PC_PLOC_BLOCK / PC_WG_1D a thread). */
#define PC_PLOC_RADIUS 16u
#define PC_PLOC_ROUNDS 64u
#define PC_PLOC_FORCED_ROUNDS 25u
#define PC_PLOC_BLOCK 256u
/* PLOC's scratch area (shaders/ploc.glsl, renderer/accel/gpu_ploc.c), in 4-byte words: a control
 * block, then a record of PC_PLOC_LOG_WORDS for each of the PC_PLOC_ROUNDS_ALL rounds (its
 * indirect dispatches: neighbour search, block passes, output; its place count, merge base and
 * merges at these offsets), ..., then clusters of PC_PLOC_CLUSTER_WORDS. */
#define PC_PLOC_ROUNDS_ALL (PC_PLOC_ROUNDS + PC_PLOC_FORCED_ROUNDS)
#define PC_PLOC_CTRL_WORDS 16u
#define PC_PLOC_LOG_WORDS 16u
#define PC_PLOC_LOG_NN_ARGS 0u
#define PC_PLOC_LOG_COUNT 3u
#define PC_PLOC_LOG_BLOCK_ARGS 4u
#define PC_PLOC_LOG_BASE 7u
#define PC_PLOC_LOG_EMIT_ARGS 8u
#define PC_PLOC_LOG_MERGES 11u
#define PC_PLOC_CLUSTER_WORDS 16u

#endif /* PC_BVH_BUILD_TYPES_H */
