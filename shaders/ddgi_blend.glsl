/* DDGI probe blend (paper Sec. 4.2, Eq. 1): one workgroup per probe of the update's list, one
 * thread per interior texel of its octahedral tile. Compiled twice, DDGI_BLEND_IRRADIANCE
 * selecting the atlas: 1 = irradiance (ddgi_blend_irradiance.comp: 8x8, weights max(0, cos),
 * in the encoded space of pc_ddgi_volume.encoding, gpu_types.h says why), 0 = distance (ddgi_blend_distance.comp: 16x16, weights cos^50,
 * mean and mean square of min(|t|, max distance)); each texel visits only the rays its weight
 * counts, as the update's weight lists give them (ddgi_weights.comp, shared by every probe; the
 * irradiance blend on a GPU walks its hemisphere's run of rays instead); each workgroup is its
 * tile's size (one
 * program sized for the distance tile left three quarters of the irradiance blend's threads
 * idle, which lavapipe pays for). The distance blend runs first.
 *
 * Hysteresis is per probe (renderer/gi/ddgi.c says why): h = min(h_max, a / (a + AGE_RAMP)) for
 * the probe's age a. The irradiance blend then measures the probe: the gap between its tile's
 * fresh and stored (encoded) luminance and the stored luminance feed the field's drift sums
 * (summed over the probes before dividing), which the CPU turns into next update's hold flag;
 * ages advance unless the field drifts and the probe still has hold budget. It also classifies
 * the probe: more than params.z back-face hits means it sits inside geometry (off); a probe
 * whose age reached the sleep age falls asleep.
 * push: globals. */
#ifndef DDGI_BLEND_IRRADIANCE
#error "ddgi_blend.glsl is the body of ddgi_blend_irradiance.comp and ddgi_blend_distance.comp"
#endif
#include "common.glsl"
#include "ddgi.glsl"

#if DDGI_BLEND_IRRADIANCE
layout(local_size_x = PC_DDGI_IRR_INTERIOR, local_size_y = PC_DDGI_IRR_INTERIOR) in;
#else
layout(local_size_x = PC_DDGI_DIST_INTERIOR, local_size_y = PC_DDGI_DIST_INTERIOR) in;
#endif

/* the atlas read back after the write (ddgi_blend measures the step the stored value really made;
 * volatile keeps the compiler from folding unpackHalf2x16(packHalf2x16(x)) back into x) */
layout(buffer_reference, std430, buffer_reference_align = 8) volatile buffer DdgiIrradianceReread
{
    uvec2 v[];
};

#define CHUNK 256u
#define TEXELS PC_DDGI_IRR_TEXELS
shared vec4 s_ray[CHUNK];
shared vec3 s_dir[CHUNK]; /* the rays' directions, for the irradiance band loop */
shared uint s_backfaces;
shared vec3 s_lum[TEXELS]; /* per irradiance texel, luminance: x stored before the
                              blend (< 0: never written), y fresh, z the gap the blend closed */

/* The irradiance blend on a GPU (vol.blend_lists 0): the rays [x, y) that can lie within 90
 * degrees of direction d. The ray set is spherical Fibonacci (ddgi.glsl fibonacci_dir), whose ray
 * i has z = 1 - (2i + 1) / n before the update's rotation, so the rays within an angle a of d form
 * one run of indices, those whose polar angle is within a of d's in the set's own frame; rays
 * outside it weigh nothing. The run holds about 90% of the rays (the hemisphere half); a warp
 * walking it reads the same shared ray in every thread, which measured faster on an H200 than
 * each thread's own weight list (0.030 against 0.052 ms, cornell+gltf, 512 probes x 256 rays;
 * 0.81 against 1.93 ms at 32 x 8 x 32 x 1024); on lavapipe the lists are faster (1.7x). */
uvec2 hemisphere_band(pc_ddgi_volume vol, vec3 d, uint n)
{
    /* R^T d: ddgi_ray_dir applies R, whose rows are vol.rotation[0..2] */
    vec3 l = vol.rotation[0].xyz * d.x + vol.rotation[1].xyz * d.y + vol.rotation[2].xyz * d.z;
    float theta = acos(clamp(l.z / max(length(l), 1e-6), -1.0, 1.0));
    float a = 0.5 * PC_PI + 1e-3; /* a margin for the rounding of the rotation */
    float z_hi = cos(max(theta - a, 0.0)), z_lo = cos(min(theta + a, PC_PI));
    /* z = 1 - (2i + 1) / n  <=>  i = ((1 - z) n - 1) / 2 */
    float fn = float(n);
    float i_lo = floor(((1.0 - z_hi) * fn - 1.0) * 0.5), i_hi = ceil(((1.0 - z_lo) * fn - 1.0) * 0.5);
    return uvec2(uint(clamp(i_lo, 0.0, fn)), uint(clamp(i_hi + 1.0, 0.0, fn)));
}

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    const bool irradiance = DDGI_BLEND_IRRADIANCE != 0;
    uint interior = irradiance ? PC_DDGI_IRR_INTERIOR : PC_DDGI_DIST_INTERIOR;
    uint side = interior + 2u;
    uint probe = ddgi_listed_probe(vol, gl_WorkGroupID.x);
    uvec2 t = gl_LocalInvocationID.xy; /* the workgroup is the tile's interior */
    /* the classification as the trace saw it (the irradiance blend updates it last) */
    bool probe_on = ddgi_probe_active(vol, probe);
    if (!probe_on && !irradiance) return; /* whole workgroup: an off probe keeps its atlas */
    uint n = probe_on ? vol.counts.w : min(vol.counts.w, PC_DDGI_INACTIVE_RAYS);
    bool mine = probe_on; /* an off probe is only re-classified, not blended */
    uint lid = gl_LocalInvocationIndex;
    uint threads = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
    if (lid == 0u) s_backfaces = 0u;
    if (lid < TEXELS) s_lum[lid] = vec3(0.0);

    /* this texel's rays of weight above zero, in increasing ray order (ddgi_weights.comp), or
     * on a GPU for irradiance the run of rays that holds them */
    bool band = irradiance && vol.blend_lists == 0u;
    vec3 texel_dir = oct_texel_dir(t, interior);
    uvec2 run = band ? hemisphere_band(vol, texel_dir, n) : uvec2(0u);
    uint texel_index = irradiance ? lid : PC_DDGI_IRR_TEXELS + lid;
    uint entries = mine && !band ? DdgiWeightCountRef(vol.weights).v[texel_index] : 0u;
    DdgiWeightRef list = DdgiWeightRef(vol.weights + PC_DDGI_WEIGHT_HEADER);
    uint k = 0u; /* the next entry */
    float back_t = 1e30, front_t = 1e30; /* thread 0: the nearest back and front face */
    uint back_ray = PC_INVALID, front_ray = PC_INVALID;
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    float max_dist = vol.origin.w;
    for (uint base = 0u; base < n; base += CHUNK) {
        barrier();
        for (uint i = lid; i < CHUNK && base + i < n; i += threads) {
            s_ray[i] = DdgiRayRef(vol.rays).v[probe * vol.counts.w + base + i];
            if (band) s_dir[i] = ddgi_ray_dir(vol, base + i);
        }
        barrier();
        uint count = min(CHUNK, n - base);
        if (irradiance && lid == 0u) /* classification: back faces among the traced rays, and
                                        for relocation the nearest back and front face */
            for (uint i = 0u; i < count; i++) {
                float d = s_ray[i].w;
                s_backfaces += d < 0.0 ? 1u : 0u;
                if (d < 0.0 && -d < back_t) back_t = -d, back_ray = base + i;
                if (d >= 0.0 && d < front_t) front_t = d, front_ray = base + i;
            }
        uint end = base + count;
        uint first = clamp(run.x, base, end) - base, last = clamp(run.y, base, end) - base;
        for (uint i = first; i < last && mine; i++) { /* band: empty unless band */
            vec4 r = s_ray[i];
            float w = ddgi_blend_weight(true, dot(texel_dir, s_dir[i]));
            if (r.w < 0.0) continue; /* back face: no irradiance */
            sum += r.rgb * w;
            wsum += w;
        }
        for (; k < entries; k++) {
            uvec2 e = list.v[k * PC_DDGI_WEIGHT_TEXELS + texel_index];
            if (e.x >= end) break; /* in a later chunk */
            vec4 r = s_ray[e.x - base];
            float w = uintBitsToFloat(e.y);
            if (irradiance) {
                if (r.w < 0.0) continue; /* back face: no irradiance */
                sum += r.rgb * w;
            } else {
                float d = min(abs(r.w), max_dist);
                sum.xy += vec2(d, d * d) * w;
            }
            wsum += w;
        }
    }
    DdgiStatsRef stats = DdgiStatsRef(vol.stats);
    vec4 st = stats.v[probe];
    float h_max = vol.params.x;
    float h = vol.info.y == 0u ? 0.0 : min(h_max, st.x / (st.x + PC_DDGI_AGE_RAMP));
    if (mine) {
        uint texel = ddgi_texel(probe, side, t.x + 1u, t.y + 1u);
        if (irradiance) {
            vec3 fresh = wsum > 1e-6 ? sum / wsum : vec3(0.0);
            if (vol.encoding != 1u) fresh = pow(fresh, vec3(1.0 / float(vol.encoding)));
            DdgiIrradianceRef a = DdgiIrradianceRef(vol.irradiance);
            uvec2 old_packed = a.v[texel];
            vec3 old = vec3(unpackHalf2x16(old_packed.x), unpackHalf2x16(old_packed.y).x);
            bool written = unpackHalf2x16(old_packed.y).y > 0.5;
            /* No asymmetric heuristics (a faster step for large drops, a minimum darkening
             * step): both bias the stored mean low, which the drift measure then sees forever;
             * the per-probe age already makes steps large after a change. */
            vec3 result = written ? mix(fresh, old, h) : fresh;
            if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
            /* stored linearly, an irradiance past the half-float range would pack to Inf (a
             * texel's mean of a few rays that met an emitter of 1e6 nits and more); encoded
             * values never come near */
            result = min(result, vec3(60000.0));
            uvec2 bits = uvec2(packHalf2x16(result.rg), packHalf2x16(vec2(result.b, 1.0)));
            a.v[texel] = bits;
            /* Measured in the stored (encoded) space, where the blend is an unbiased mean of the
             * fresh values: a settled probe shows no drift. The gap between fresh and stored is taken
             * from the step the stored value really made, as half floats, divided by 1 - h: a
             * gap too small to move a half float (a few 1/10000 relative, over 1 - h) cannot be
             * closed by more updates and is no drift. */
            uvec2 kept = DdgiIrradianceReread(vol.irradiance).v[texel];
            vec3 stored = vec3(unpackHalf2x16(kept.x), unpackHalf2x16(kept.y).x);
            if (any(isnan(old)) || any(isinf(old))) old = vec3(0.0);
            float lum_old = luminance(max(old, vec3(0.0)));
            float moved = luminance(max(stored, vec3(0.0))) - lum_old;
            s_lum[t.y * PC_DDGI_IRR_INTERIOR + t.x] =
                vec3(written ? lum_old : -1.0, luminance(max(fresh, vec3(0.0))),
                     h < 1.0 ? moved / (1.0 - h) : 0.0);
        } else {
            DdgiDistanceRef a = DdgiDistanceRef(vol.distance);
            vec2 fresh = wsum > 1e-6 ? sum.xy / wsum : a.v[texel];
            vec2 result = mix(fresh, a.v[texel], h);
            if (any(isnan(result)) || any(isinf(result))) result = vec2(max_dist, max_dist * max_dist);
            a.v[texel] = result;
        }
    }
    if (!irradiance) return;
    barrier();
    if (lid != 0u) return;
    /* thread 0: measure, classify, age */
    DdgiControlRef ctrl = DdgiControlRef(vol.ctrl);
    bool inside = float(s_backfaces) > vol.params.z * float(n);
    uint state;
    /* Off and back on keep the age, unless a wake event (geometry moved) listed the probe
     * (st.w = 2, ddgi_select.comp): then it starts over. A probe on a surface (half its rays
     * behind it, classified by how a few rays graze) can flip between off and on at every
     * re-check; when each return reset its age it never slept, and the field never converged
     * (probes on the walls of a room, tests/bench/results/h200/narrow_gap_spacing.txt). Kept, its
     * ages still add up to the sleep age, so the bound below holds for it too. */
    if (!probe_on) {
        /* re-checked: by a wake event, or periodically, PC_DDGI_OFF_RECHECK updates after the
         * last check, which the age counts as if blended (so off stints of a flipping probe do
         * not stretch the bound either) */
        if (st.w > 1.5)
            st.xy = vec2(0.0);
        else
            st.x += float(PC_DDGI_OFF_RECHECK);
    }
    /* Relocation (PC_DDGI_RELOCATE_*), during a probe's first blends after a reset or a geometry
     * wake (age plus held updates: one per blend). A probe inside a wall thinner than the
     * spacing goes off, and the cells around it lose a corner; moved through the wall's near
     * face it stays on (measured: tests/bench/results/h200/relocation.txt). */
    vec4 pd = DdgiProbeRef(vol.probes).v[probe];
    bool moved_out = false;
    if (vol.relocate != 0u && st.x + st.y < float(PC_DDGI_RELOCATE_BLENDS)) {
        float clearance = PC_DDGI_RELOCATE_CLEARANCE *
                          min(vol.spacing.x, min(vol.spacing.y, vol.spacing.z));
        vec3 move = vec3(0.0);
        if (inside && back_ray != PC_INVALID)
            move = ddgi_ray_dir(vol, back_ray) * (back_t / DDGI_BACKFACE_DISTANCE + clearance);
        else if (!inside && front_ray != PC_INVALID && front_t < clearance)
            move = -ddgi_ray_dir(vol, front_ray) * (clearance - front_t);
        vec3 offset = pd.xyz + move;
        if (any(notEqual(move, vec3(0.0))) &&
            all(lessThanEqual(abs(offset), PC_DDGI_RELOCATE_LIMIT * vol.spacing.xyz))) {
            pd.xyz = offset;
            /* traced again at its new place by the next update, with all its rays; the move
             * counts as a blend, so a probe moves at most PC_DDGI_RELOCATE_BLENDS times */
            moved_out = inside;
            if (inside) st.x += 1.0;
        }
    }
    if (moved_out) {
        state = PC_DDGI_PROBE_AWAKE;
    } else if (inside) {
        state = PC_DDGI_PROBE_OFF;
    } else if (!probe_on) {
        state = PC_DDGI_PROBE_AWAKE; /* back on: blended from the next update */
    } else {
        vec3 m = vec3(0.0);
        bool measured = true; /* every texel held a value before this blend */
        for (uint i = 0u; i < TEXELS; i++) {
            measured = measured && s_lum[i].x >= 0.0;
            m += vec3(max(s_lum[i].xy, vec2(0.0)), s_lum[i].z);
        }
        /* The drift sums, in fixed point (params.w units; the CPU keeps a typical probe near
         * 1/64 of the per-probe limit): the gap between fresh and stored, and stored, over the
         * probes with a stored value, and fresh over all. Summed before dividing, the ratio has
         * no bias from noise, and a probe weighs by its brightness, so noisy single probes (a
         * sun patch, rare hits of a small emitter) and dark ones leave no mean drift (a ratio
         * per probe would: its mean relative change is not zero when its noise is large). */
        float k = vol.params.w;
        float limit = float(PC_DDGI_DRIFT_RANGE / max(ddgi_probe_count(vol), 1u));
        float fresh_q = clamp(round(m.y * k), 0.0, limit);
        if (isnan(fresh_q)) fresh_q = 0.0;
        atomicAdd(ctrl.drift.w, int(fresh_q));
        if (measured) {
            float stored_q = clamp(round(m.x * k), 0.0, limit);
            float gap_q = clamp(round(m.z * k), -limit, limit);
            if (isnan(stored_q) || isnan(gap_q)) stored_q = gap_q = 0.0;
            atomicAdd(ctrl.drift.x, int(gap_q));
            atomicAdd(ctrl.drift.y, int(stored_q));
            atomicAdd(ctrl.drift.z, 1);
        }
        /* Ages hold while the field drifts, for at most PC_DDGI_HOLD_FACTOR sleep ages since the
         * probe's last wake (st.y counts the held updates): every probe sleeps within
         * (1 + PC_DDGI_HOLD_FACTOR) sleep ages, whatever the measure says. */
        float sleep_age = uintBitsToFloat(vol.control.y);
        if (vol.control.x != 0u && st.y < float(PC_DDGI_HOLD_FACTOR) * sleep_age)
            st.y += 1.0;
        else
            st.x += 1.0;
        state = st.x >= sleep_age ? PC_DDGI_PROBE_SLEEPING : PC_DDGI_PROBE_AWAKE;
    }
    if (state == PC_DDGI_PROBE_AWAKE) atomicAdd(ctrl.after.x, 1u);
    else if (state == PC_DDGI_PROBE_SLEEPING) atomicAdd(ctrl.after.y, 1u);
    else atomicAdd(ctrl.after.z, 1u);
    st.w = 0.0;
    stats.v[probe] = st;
    pd.w = float(state);
    DdgiProbeRef(vol.probes).v[probe] = pd;
}
