// ploc_round.comp: one round of PLOC clustering (Meister and Bittner 2018, "Parallel Locally-
// Ordered Clustering for Bounding Volume Hierarchy Construction"; renderer/accel/gpu_ploc.c
// records PC_PLOC_ROUNDS_ALL rounds, the rounds after the last merge dispatch no groups). The
// clusters of round r sit in places 0..count-1 of cur(r) (shaders/ploc.glsl), in Morton order.
// Four phases (params.w & 15), a barrier between each:
//   0: one thread a place finds its nearest neighbour: the place within PC_PLOC_RADIUS either
//      side whose union box has the least area (ties: the nearer place, and between the two at
//      distance 1, the place's partner in its aligned pair, i ^ 1, so that equal boxes pair up
//      instead of chaining: tests/renderer/ploc_ref.c, the reference, chooses the same). The
//      workgroup reads its window of boxes into shared memory once. Forced rounds (recorded
//      after the clustering rounds) pair i with i ^ 1, so that the build ends whatever the boxes.
//   1: one workgroup a block of PC_PLOC_BLOCK places sums what its places give the next round:
//      a place whose neighbour chose it too (mutual) merges with it at the lower place, the
//      higher place goes, any other place is kept;
//   2: one workgroup scans the blocks' sums (exclusive), records the round's merge base and
//      merges and the next round's count, and writes the next round's dispatches (none below
//      two clusters) and this round's output dispatch (shaders/ploc_emit.comp);
//   3: one workgroup a block writes the next round's places, and each merge's cluster: the union
//      box, its SAH cost, and its collapse into one leaf where a leaf of at most max_leaf
//      triangles, weighted by PC_LBVH_LEAF_WEIGHT, costs no more than the split (ploc_ref.c's
//      collapse, made here because both children are final).
// Push constants (pc_push): buf2 = scratch; params.x = n, params.y = the PLOC area's word offset,
// params.z = the round, params.w = phase | max_leaf << 4 | forced << 8 | groups a row << 16.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"
#include "ploc.glsl"

layout(local_size_x = PC_WG_1D) in;

layout(push_constant) uniform Push
{
    pc_push pc;
};

#define WINDOW (PC_WG_1D + 2u * PC_PLOC_RADIUS)
#define PER_THREAD (PC_PLOC_BLOCK / PC_WG_1D)
shared vec3 g_lo[WINDOW];
shared vec3 g_hi[WINDOW];
shared uvec2 g_sums[PC_WG_1D];

// What place i gives the next round: x places (0 or 1), y merges (0 or 1).
uvec2 ploc_fate(LbvhUints s, uint nn_at, uint i)
{
    uint j = s.v[nn_at + i];
    bool mutual = j != i && s.v[nn_at + j] == i;
    if (!mutual) return uvec2(1u, 0u);
    return i < j ? uvec2(1u, 1u) : uvec2(0u);
}

// Thread 0 turns g_sums into its exclusive prefix; returns the total.
uvec2 ploc_scan_shared()
{
    barrier();
    if (gl_LocalInvocationID.x == 0u) {
        uvec2 run = uvec2(0u);
        for (uint k = 0u; k < PC_WG_1D; k++) {
            uvec2 v = g_sums[k];
            g_sums[k] = run;
            run += v;
        }
        g_sums[0] = run; // the total, read below, then the first prefix (zero) put back
    }
    barrier();
    uvec2 total = g_sums[0];
    barrier();
    if (gl_LocalInvocationID.x == 0u) g_sums[0] = uvec2(0u);
    barrier();
    return total;
}

void main()
{
    uint n = pc.params.x, at = pc.params.y, round = pc.params.z;
    uint phase = pc.params.w & 15u, max_leaf = (pc.params.w >> 4) & 15u;
    bool forced = ((pc.params.w >> 8) & 1u) != 0u;
    uint row = pc.params.w >> 16, t = gl_LocalInvocationID.x;
    LbvhUints s = LbvhUints(pc.buf2);
    uint log_at = ploc_log_at(at, round);
    uint count = s.v[log_at + PC_PLOC_LOG_COUNT];
    uint cur = ploc_cur_at(n, at, round), next = ploc_cur_at(n, at, round + 1u);
    uint nn_at = ploc_nn_at(n, at), sums = ploc_sums_at(n, at);
    PlocClusters cl = ploc_clusters(pc.buf2, n, at);

    if (phase == 0u) { // nearest neighbours
        uint i = lbvh_thread();
        if (forced) {
            if (i < count) s.v[nn_at + i] = (i ^ 1u) < count ? i ^ 1u : i;
            return;
        }
        int first = int(lbvh_group() * PC_WG_1D) - int(PC_PLOC_RADIUS);
        for (uint e = t; e < WINDOW; e += PC_WG_1D) {
            int p = first + int(e);
            if (p >= 0 && p < int(count)) {
                uint id = s.v[cur + uint(p)];
                g_lo[e] = cl.c[id].lo.xyz;
                g_hi[e] = cl.c[id].hi.xyz;
            }
        }
        barrier();
        if (i >= count) return;
        uint lo = i > PC_PLOC_RADIUS ? i - PC_PLOC_RADIUS : 0u;
        uint hi = min(i + PC_PLOC_RADIUS, count - 1u);
        vec3 ilo = g_lo[int(i) - first], ihi = g_hi[int(i) - first];
        float best = 0.0;
        uint best_j = 0xffffffffu, best_d = 0xffffffffu;
        for (uint j = lo; j <= hi; j++) {
            if (j == i) continue;
            uint e = uint(int(j) - first);
            float a = ploc_half_area(min(ilo, g_lo[e]), max(ihi, g_hi[e]));
            uint d = j > i ? j - i : i - j;
            bool nearer = d < best_d || (d == best_d && d == 1u && j == (i ^ 1u));
            if (best_j == 0xffffffffu || a < best || (a == best && nearer)) {
                best = a;
                best_d = d;
                best_j = j;
            }
        }
        s.v[nn_at + i] = best_j;
        return;
    }

    if (phase == 2u) { // the blocks' prefix, the round's record, the next round's dispatches
        if (count < 2u) return;
        uint blocks = ploc_blocks(count);
        uint chunk = (blocks + PC_WG_1D - 1u) / PC_WG_1D;
        uint a = min(t * chunk, blocks), b = min(a + chunk, blocks);
        uvec2 sum = uvec2(0u);
        for (uint k = a; k < b; k++)
            sum += uvec2(s.v[sums + 2u * k], s.v[sums + 2u * k + 1u]);
        g_sums[t] = sum;
        uvec2 total = ploc_scan_shared();
        uvec2 run = g_sums[t];
        for (uint k = a; k < b; k++) {
            uvec2 v = uvec2(s.v[sums + 2u * k], s.v[sums + 2u * k + 1u]);
            s.v[sums + 2u * k] = run.x;
            s.v[sums + 2u * k + 1u] = run.y;
            run += v;
        }
        if (t != 0u) return;
        uint made = s.v[at];
        s.v[log_at + PC_PLOC_LOG_BASE] = made;
        s.v[log_at + PC_PLOC_LOG_MERGES] = total.y;
        s.v[at] = made + total.y;
        ploc_write_args(s, log_at + PC_PLOC_LOG_EMIT_ARGS, (total.y + PC_WG_1D - 1u) / PC_WG_1D,
                        row);
        if (round + 1u < PC_PLOC_ROUNDS_ALL) {
            uint next_log = ploc_log_at(at, round + 1u);
            s.v[next_log + PC_PLOC_LOG_COUNT] = total.x;
            if (total.x >= 2u) {
                ploc_write_args(s, next_log + PC_PLOC_LOG_NN_ARGS,
                                (total.x + PC_WG_1D - 1u) / PC_WG_1D, row);
                ploc_write_args(s, next_log + PC_PLOC_LOG_BLOCK_ARGS, ploc_blocks(total.x), row);
            }
        }
        return;
    }

    // phases 1 and 3: a workgroup a block, PER_THREAD consecutive places a thread (the last
    // row's groups past the blocks return: their sums would land past the sums' words)
    uint block = lbvh_group();
    if (block >= ploc_blocks(count)) return;
    uint p0 = block * PC_PLOC_BLOCK + t * PER_THREAD;
    uvec2 fate[PER_THREAD], mine = uvec2(0u);
    for (uint k = 0u; k < PER_THREAD; k++) {
        uint i = p0 + k;
        fate[k] = i < count ? ploc_fate(s, nn_at, i) : uvec2(0u);
        mine += fate[k];
    }
    g_sums[t] = mine;
    uvec2 total = ploc_scan_shared();
    if (phase == 1u) {
        if (t == 0u) {
            s.v[sums + 2u * block] = total.x;
            s.v[sums + 2u * block + 1u] = total.y;
        }
        return;
    }
    uint made = s.v[log_at + PC_PLOC_LOG_BASE];
    uvec2 run = g_sums[t] + uvec2(s.v[sums + 2u * block], s.v[sums + 2u * block + 1u]);
    for (uint k = 0u; k < PER_THREAD; k++) {
        uint i = p0 + k;
        if (fate[k].x == 0u) continue;
        uint id = s.v[cur + i];
        if (fate[k].y != 0u) { // the merge of i and its neighbour, a new cluster
            uint left = id, right = s.v[cur + s.v[nn_at + i]];
            id = n + made + run.y;
            PlocCluster l = cl.c[left], r = cl.c[right];
            PlocCluster m;
            m.lo.xyz = min(l.lo.xyz, r.lo.xyz);
            m.hi.xyz = max(l.hi.xyz, r.hi.xyz);
            precise float area = ploc_half_area(m.lo.xyz, m.hi.xyz);
            precise float split = area + l.lo.w + r.lo.w;
            uint tris = (l.info.x & PLOC_COUNT_MASK) + (r.info.x & PLOC_COUNT_MASK);
            uint nonfinite = l.info.y + r.info.y;
            bool mixed = nonfinite != 0u && nonfinite != tris;
            precise float leaf = PC_LBVH_LEAF_WEIGHT * area * float(tris);
            bool collapse = !mixed && tris <= max_leaf && leaf <= split;
            precise float leaf_cost = area * float(tris);
            m.lo.w = collapse ? leaf_cost : split;
            m.hi.w = collapse ? 0.0 : 1.0 + max(l.hi.w, r.hi.w);
            m.info = uvec4(tris | (collapse ? PLOC_COLLAPSED : 0u), nonfinite, left, right);
            uint below = collapse ? 0u : 2u + l.out_.x + r.out_.x;
            bool root = id == 2u * n - 2u;
            m.out_ = uvec4(below, root ? 0u : 0xffffffffu, 1u, 0u);
            cl.c[id] = m;
        }
        s.v[next + run.x] = id;
        run += fate[k];
    }
}
