/* ddgi.glsl: the DDGI probe field (Majercik, Guertin, Nowrouzezahrai, McGuire, JCGT 2019):
 * probe addressing, octahedral maps (Sec. 3, after Cigolle et al. 2014), spherical Fibonacci
 * ray directions, and the irradiance query with visibility (Sec. 4-5). Included after
 * common.glsl. Constants follow shared/notes/ddgi-reference.md. */
#ifndef PC_DDGI_GLSL
#define PC_DDGI_GLSL

layout(buffer_reference, std430, buffer_reference_align = 8) buffer DdgiIrradianceRef { uvec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer DdgiDistanceRef { vec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DdgiRayRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DdgiProbeRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DdgiStatsRef { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer DdgiListRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer DdgiOrderRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DdgiControlRef
{
    uvec4 trace_args;
    uvec4 blend_args;
    uvec4 border_args;
    uvec4 before;
    uvec4 after;
    ivec4 drift;
    uvec4 shade_args;
};
layout(buffer_reference, std430, buffer_reference_align = 8) buffer DdgiWeightRef { uvec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer DdgiWeightCountRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer DdgiWakeRef
{
    pc_ddgi_wake v[];
};

/* ---- octahedral mapping ------------------------------------------------------------- */
vec2 sign_not_zero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

/* Unit direction -> [-1, 1]^2. */
vec2 oct_encode(vec3 n)
{
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z >= 0.0 ? p : (1.0 - abs(p.yx)) * sign_not_zero(p);
}

/* [-1, 1]^2 -> unit direction. */
vec3 oct_decode(vec2 p)
{
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    return normalize(n);
}

/* Direction at the centre of interior texel t (0..interior-1) of an octahedral tile. */
vec3 oct_texel_dir(uvec2 t, uint interior)
{
    return oct_decode((vec2(t) + 0.5) / float(interior) * 2.0 - 1.0);
}

/* ---- rays: spherical Fibonacci set, rotated each update --------------------------------- */
vec3 fibonacci_dir(uint i, uint n)
{
    const float golden = 0.61803398874989484820; /* sqrt(5) * 0.5 + 0.5 - 1 */
    float phi = 2.0 * PC_PI * fract(float(i) * golden);
    float cos_theta = 1.0 - (2.0 * float(i) + 1.0) / float(n);
    float sin_theta = sqrt(clamp(1.0 - cos_theta * cos_theta, 0.0, 1.0));
    return vec3(cos(phi) * sin_theta, sin(phi) * sin_theta, cos_theta);
}

vec3 ddgi_ray_dir(pc_ddgi_volume vol, uint i)
{
    vec3 d = fibonacci_dir(i, vol.counts.w);
    return normalize(vec3(dot(vol.rotation[0].xyz, d), dot(vol.rotation[1].xyz, d),
                          dot(vol.rotation[2].xyz, d)));
}

/* Probe rays that hit the back of a single-sided surface store -DDGI_BACKFACE_DISTANCE times
 * their hit distance (ddgi_trace.comp): negative marks the back face (classification,
 * relocation), and the short distance makes the distance blend see such a probe as enclosed. */
#define DDGI_BACKFACE_DISTANCE 0.2

/* ---- blend weights ------------------------------------------------------------------- */
/* cos^50 falls below 1.5e-5 beyond 37 degrees: the distance blend leaves out the rays farther
 * than that from its texel */
#define DDGI_DIST_MIN_COS 0.8

/* The weight of a ray at cosine c from a texel's direction (paper Sec. 4.2): the irradiance
 * blend's max(0, c), the distance blend's c^50 (0 beyond DDGI_DIST_MIN_COS). */
float ddgi_blend_weight(bool irradiance, float c)
{
    if (irradiance) return max(0.0, c);
    return c > DDGI_DIST_MIN_COS ? pow(c, 50.0) : 0.0;
}

/* ---- probe addressing ---------------------------------------------------------------- */
uint ddgi_probe_count(pc_ddgi_volume vol) { return vol.counts.x * vol.counts.y * vol.counts.z; }

uint ddgi_probe_index(pc_ddgi_volume vol, ivec3 p)
{
    return uint(p.x) + vol.counts.x * (uint(p.y) + vol.counts.y * uint(p.z));
}

ivec3 ddgi_probe_coord(pc_ddgi_volume vol, uint index)
{
    return ivec3(index % vol.counts.x, (index / vol.counts.x) % vol.counts.y,
                 index / (vol.counts.x * vol.counts.y));
}

vec3 ddgi_probe_position(pc_ddgi_volume vol, uint index)
{
    vec3 offset = DdgiProbeRef(vol.probes).v[index].xyz;
    return vol.origin.xyz + vec3(ddgi_probe_coord(vol, index)) * vol.spacing.xyz + offset;
}

bool ddgi_probe_active(pc_ddgi_volume vol, uint index)
{
    return (uint(DdgiProbeRef(vol.probes).v[index].w) & PC_DDGI_PROBE_ACTIVE) != 0u;
}

uint ddgi_probe_state(pc_ddgi_volume vol, uint index)
{
    return uint(DdgiProbeRef(vol.probes).v[index].w);
}

/* The probe an update pass works on: entry `slot` of this update's list. */
uint ddgi_listed_probe(pc_ddgi_volume vol, uint slot) { return DdgiListRef(vol.list).v[slot]; }

/* Radiance a probe ray brings back without shading: a miss (tri PC_INVALID) sees the sky; a
 * back face of a single-sided surface carries nothing. */
vec3 ddgi_miss_radiance(pc_environment env, pc_ddgi_volume vol, uint ray, uint tri)
{
    vec3 radiance = tri == PC_INVALID ? env_radiance(env, ddgi_ray_dir(vol, ray)) : vec3(0.0);
    return any(isnan(radiance)) || any(isinf(radiance)) ? vec3(0.0) : radiance;
}

/* The ray thread x of a probe's workgroups traces and shades (see pc_ddgi_volume.order);
 * threads past the ray count keep their index (and do nothing). */
uint ddgi_thread_ray(pc_ddgi_volume vol, uint x)
{
    return x < vol.counts.w ? DdgiOrderRef(vol.order).v[x] : x;
}

/* Texel (x, y) of probe's tile (side = interior + 2, border included). */
uint ddgi_texel(uint probe, uint side, uint x, uint y) { return (probe * side + y) * side + x; }

/* ---- atlas sampling (manual bilinear inside one bordered tile) ------------------------ */
vec3 ddgi_decode_irradiance(pc_ddgi_volume vol, uvec2 packed)
{
    vec3 enc = max(vec3(unpackHalf2x16(packed.x), unpackHalf2x16(packed.y).x), vec3(0.0));
#if PC_DDGI_ENCODING_PAPER != 5
#error "ddgi_decode_irradiance raises to the 5th power"
#endif
    if (vol.encoding != uint(PC_DDGI_ENCODING_PAPER)) return enc; /* linear */
    vec3 enc2 = enc * enc;
    return enc2 * enc2 * enc;
}

/* Tile coordinates (texel units, border included) of direction dir. */
vec2 ddgi_tile_coord(vec3 dir, uint interior)
{
    return (oct_encode(dir) * 0.5 + 0.5) * float(interior) + 1.0;
}

/* Bilinear weights and the four texel indices around tile coordinate c. */
void ddgi_bilinear(uint probe, uint side, vec2 c, out uvec4 idx, out vec4 w)
{
    vec2 p = clamp(c - 0.5, vec2(0.0), vec2(float(side) - 1.001));
    uvec2 i0 = uvec2(floor(p));
    vec2 f = p - vec2(i0);
    uvec2 i1 = min(i0 + 1u, uvec2(side - 1u));
    idx = uvec4(ddgi_texel(probe, side, i0.x, i0.y), ddgi_texel(probe, side, i1.x, i0.y),
                ddgi_texel(probe, side, i0.x, i1.y), ddgi_texel(probe, side, i1.x, i1.y));
    w = vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
}

/* Stored mean cosine-weighted radiance (E / pi) of probe toward normal n, decoded. */
vec3 ddgi_sample_irradiance(pc_ddgi_volume vol, uint probe, vec3 n)
{
    uvec4 idx;
    vec4 w;
    ddgi_bilinear(probe, vol.info.z, ddgi_tile_coord(n, PC_DDGI_IRR_INTERIOR), idx, w);
    DdgiIrradianceRef a = DdgiIrradianceRef(vol.irradiance);
    return ddgi_decode_irradiance(vol, a.v[idx.x]) * w.x +
           ddgi_decode_irradiance(vol, a.v[idx.y]) * w.y +
           ddgi_decode_irradiance(vol, a.v[idx.z]) * w.z +
           ddgi_decode_irradiance(vol, a.v[idx.w]) * w.w;
}

/* (mean distance, mean squared distance) of probe in direction dir. */
vec2 ddgi_sample_distance(pc_ddgi_volume vol, uint probe, vec3 dir)
{
    uvec4 idx;
    vec4 w;
    ddgi_bilinear(probe, vol.info.w, ddgi_tile_coord(dir, PC_DDGI_DIST_INTERIOR), idx, w);
    DdgiDistanceRef a = DdgiDistanceRef(vol.distance);
    return a.v[idx.x] * w.x + a.v[idx.y] * w.y + a.v[idx.z] * w.z + a.v[idx.w] * w.w;
}

/* ---- the irradiance query ----------------------------------------------------------- */

/* Bits 0-2 of a probe's stats.z: geometry crosses the segment from the probe to its +x, +y, +z
 * neighbour (ddgi_select.comp traces them every update). */
uint ddgi_probe_edges(pc_ddgi_volume vol, uint index)
{
    return uint(DdgiStatsRef(vol.stats).v[index].z);
}

/* Irradiance E at surface point p with unit normal n, seen from direction v (unit, toward
 * the viewer or the tracing probe). mode PC_GI_CLASSIC uses trilinear weights only;
 * PC_GI_DDGI adds the back-face wrap, Chebyshev visibility and small-weight crush, with the
 * sample point biased along n and v by a fraction of the probe spacing (2021 paper form).
 * Beyond half a spacing outside the probe hull the result fades, over one spacing, to sky_e,
 * the environment's irradiance at n (env_irradiance).
 * Visibility rays (PC_DDGI_VIS_*; probe_hit: the caller shades a probe-ray hit, else a camera
 * pixel or a reflection hit): where geometry crosses a cage edge between two active probes,
 * each of them that still has weight gets a ray from the biased point; blocked, its weight
 * drops to that of a probe Chebyshev rejects outright. The filtered distances cannot tell a
 * wall thinner than their spread (a 5 cm wall seen from 2 m, next to a depth edge) from open
 * space; the ray can (issue 28: thin-walls +222% -> -2.1% against the path tracer).
 * v_reach: how far along v the space is known free (half the ray that found p): the bias along v
 * stops there. A reflection ray from a pixel next to a room's corner meets the other wall a few
 * centimetres away; biased by the full 0.8 x 0.3 x 0.75 spacing back along the ray, the point
 * landed behind the pixel's own wall, outside, where the visibility rays saw the sunlit probes:
 * bright seams along the corners and speckles on glossy walls (thin-walls+metal +142% against
 * the path tracer). Probe-ray hits pass no limit: their rays start at the probe, in free space.
 * Callers make sure the field holds at least one update. */
/* Corner i (bit 0: +x, 1: +y, 2: +z) of the cell at base: its probe index. */
uint ddgi_corner_probe(pc_ddgi_volume vol, ivec3 base, uint i)
{
    ivec3 pc = min(base + ivec3(i & 1u, (i >> 1) & 1u, (i >> 2) & 1u), ivec3(vol.counts.xyz) - 1);
    return ddgi_probe_index(vol, pc);
}

/* Corner i's trilinear weight at alpha (the point's place in its cell), at least 0.001 a axis. */
float ddgi_trilinear(vec3 alpha, uint i)
{
    vec3 tri = max(vec3(0.001), mix(1.0 - alpha, alpha, vec3(i & 1u, (i >> 1) & 1u, (i >> 2) & 1u)));
    return tri.x * tri.y * tri.z;
}

/* clear_sigmas > 0: a visibility ray is left out where the probe's distances say the segment is
 * clear, the texel's mean more than clear_sigmas deviations beyond the point (the probe's rays
 * toward it all went past it); a wall in between, or a texel straddling its edge, keeps the mean
 * below that. Camera pixels' queries pass DDGI_VIS_CLEAR_SIGMAS (1): on an NVIDIA H200 it left
 * every measured image unchanged (bias within 0.3 points, relMSE within noise) and cut the
 * 1080p pass 7-25% (builtin:interior 1.47 -> 1.24 ms, two-rooms 0.91 -> 0.69 ms;
 * tests/bench/results/h200/visibility_skip.txt). Reflection hits and probe-ray hits pass 0
 * (every ray traced): with 1 at reflection hits too, the metallic thin-walls room's relMSE
 * doubled (0.046 -> 0.097). */
#define DDGI_VIS_CLEAR_SIGMAS 1.0
/* The sample point's bias, in units of the bias scale (params.y): along n and along v. */
#define DDGI_NORMAL_BIAS 0.2
#define DDGI_VIEW_BIAS 0.8

/* The masked-lanes form of ddgi_irradiance (common.glsl) takes its corners apart with these.
 * The weight of probe (a corner of the query's cell) before its trilinear factor: the back-face
 * wrap, Chebyshev visibility and small-weight crush of mode PC_GI_DDGI (1 in classic mode), as
 * ddgi_irradiance's GPU loop computes them; 0 when the probe is inactive. ray: it is an active corner of a crossed cell with weight left,
 * whose distances do not show the segment clear (ddgi_irradiance says when). */
float ddgi_corner_weight(pc_ddgi_volume vol, uint mode, uint probe, vec3 p, vec3 n, vec3 biased,
                         bool crossed, float clear_sigmas, out bool ray)
{
    ray = false;
    if (!ddgi_probe_active(vol, probe)) return 0.0;
    if (mode != PC_GI_DDGI) return 1.0;
    vec3 probe_pos = ddgi_probe_position(vol, probe);
    vec3 to_probe = probe_pos - p;
    float len = length(to_probe);
    vec3 dir_to_probe = len > 0.0 ? to_probe / len : n;
    float wrap = (dot(dir_to_probe, n) + 1.0) * 0.5;
    float w = wrap * wrap + 0.2;
    vec3 probe_to_point = biased - probe_pos;
    float r = length(probe_to_point);
    vec3 dir = r > 0.0 ? probe_to_point / r : n;
    vec2 moments = ddgi_sample_distance(vol, probe, dir);
    float mean = moments.x;
    float variance = abs(moments.y - mean * mean);
    if (r > mean) {
        float d = r - mean;
        float cheb = variance / (variance + d * d);
        w *= max(0.05, cheb * cheb * cheb);
    }
    w = max(1e-6, w);
    if (w < 0.2) w *= w * w / 0.04;
    bool clear = clear_sigmas > 0.0 && mean - clear_sigmas * sqrt(variance) > r;
    ray = crossed && w > 1e-3 && !clear;
    return w;
}

/* Whether geometry lies between the biased query point and probe (a visibility ray). */
bool ddgi_corner_blocked(pc_ddgi_volume vol, pc_scene_refs scene, uint probe, vec3 biased)
{
    vec3 to = ddgi_probe_position(vol, probe) - biased;
    float dist = length(to);
    pc_hit h;
    return dist > 0.0 && trace_ray(scene, biased, to / dist, 0.0, dist, PC_TRACE_ANY_HIT, h);
}
vec3 ddgi_irradiance(pc_ddgi_volume vol, pc_scene_refs scene, bool probe_hit, vec3 sky_e, vec3 p,
                     vec3 n, vec3 v, float v_reach, float clear_sigmas)
{
    uint mode = vol.info.x;
    uint vis = uint(vol.spacing.w);
    bool vis_rays = vis == PC_DDGI_VIS_ALL || (vis == PC_DDGI_VIS_PROBES && probe_hit);
    if (mode == PC_GI_OFF) return vec3(0.0);
    vec3 biased = p + DDGI_NORMAL_BIAS * vol.params.y * n + min(DDGI_VIEW_BIAS * vol.params.y, v_reach) * v;
    vec3 grid = (biased - vol.origin.xyz) / vol.spacing.xyz;
    vec3 last = vec3(vol.counts.xyz) - 1.0;
    /* fade: 1 up to half a spacing outside the probe hull (the default grid puts probes at
     * cell centres, half a spacing inside the scene bounds), 0 one spacing further out */
    vec3 outside = max(-grid, grid - last);
    float fade = clamp(1.5 - max(outside.x, max(outside.y, outside.z)), 0.0, 1.0);
    if (fade <= 0.0) return sky_e;
    ivec3 base = clamp(ivec3(floor(grid)), ivec3(0), max(ivec3(vol.counts.xyz) - 2, ivec3(0)));
    vec3 alpha = clamp(grid - vec3(base), 0.0, 1.0);
    /* a cell whose probes geometry separates (an edge of its cage crossed: a wall thinner than
     * the spacing, furniture) gets visibility rays: Chebyshev's test on filtered distances lets
     * light through such walls where a texel straddles a depth edge (issue 28); elsewhere the
     * test alone decides, as in the paper */
    bool crossed = false; /* a cage edge of the cell between two active probes is crossed */
    if (mode == PC_GI_DDGI && vis_rays) {
        uint live = 0u, edges[8];
        for (uint i = 0u; i < 8u; i++) {
            ivec3 pc = min(base + ivec3(i & 1u, (i >> 1) & 1u, (i >> 2) & 1u),
                           ivec3(vol.counts.xyz) - 1);
            uint probe = ddgi_probe_index(vol, pc);
            edges[i] = ddgi_probe_edges(vol, probe);
            if (ddgi_probe_active(vol, probe)) live |= 1u << i;
        }
        /* an edge into a probe that is off (inside geometry: not sampled) says only that the
         * geometry is solid there; one between two active probes, that it is thinner than the
         * spacing. Then every active corner gets its ray, not only the crossed edge's ends: at a
         * wall's outer corner the cell's far corner outside is joined to the inside probe only by
         * a face or body diagonal, its own edges run clear of the building, and Chebyshev on its
         * distance texel straddling the corner let the sun in (thin-walls at 12x3x12 probes:
         * +103% against 16x4x16). */
        for (uint i = 0u; i < 8u; i++) /* no early exit: a GPU unrolls this form (H200: 3%) */
            for (uint k = 0u; k < 3u; k++) {
                uint j = i | (1u << k);
                if (j != i && (edges[i] & (1u << k)) != 0u && (live & (1u << i)) != 0u &&
                    (live & (1u << j)) != 0u)
                    crossed = true;
            }
    }
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
#if !PC_MASKED_LANES
    /* The corners' weights and visibility rays in one loop, the form a GPU runs fastest (an H200,
     * builtin:interior 1080p: this 1.58 ms, the masked form's helper functions 1.71 ms). The
     * masked form below computes the same weights (ddgi_corner_weight); test_gpu_materials
     * renders both and requires the same image, bit for bit. */
    for (uint i = 0u; i < 8u; i++) {
        ivec3 off = ivec3(i & 1u, (i >> 1) & 1u, (i >> 2) & 1u);
        ivec3 pc = min(base + off, ivec3(vol.counts.xyz) - 1);
        uint probe = ddgi_probe_index(vol, pc);
        if (!ddgi_probe_active(vol, probe)) continue;
        vec3 tri = max(vec3(0.001), mix(1.0 - alpha, alpha, vec3(off)));
        float trilinear = tri.x * tri.y * tri.z;
        float w = 1.0;
        if (mode == PC_GI_DDGI) {
            vec3 probe_pos = ddgi_probe_position(vol, probe);
            vec3 to_probe = probe_pos - p;
            float len = length(to_probe);
            vec3 dir_to_probe = len > 0.0 ? to_probe / len : n;
            float wrap = (dot(dir_to_probe, n) + 1.0) * 0.5;
            w *= wrap * wrap + 0.2;
            vec3 probe_to_point = biased - probe_pos;
            float r = length(probe_to_point);
            vec3 dir = r > 0.0 ? probe_to_point / r : n;
            vec2 moments = ddgi_sample_distance(vol, probe, dir);
            float mean = moments.x;
            float variance = abs(moments.y - mean * mean);
            if (r > mean) {
                float d = r - mean;
                float cheb = variance / (variance + d * d);
                w *= max(0.05, cheb * cheb * cheb);
            }
            w = max(1e-6, w);
            if (w < 0.2) w *= w * w / 0.04;
            bool clear = clear_sigmas > 0.0 && mean - clear_sigmas * sqrt(variance) > r;
            if (crossed && w > 1e-3 && !clear) { /* an active corner of a crossed cell */
                vec3 to = probe_pos - biased;
                float dist = length(to);
                pc_hit h;
                if (dist > 0.0 &&
                    trace_ray(scene, biased, to / dist, 0.0, dist, PC_TRACE_ANY_HIT, h))
                    w = 1e-6;
            }
        }
        w *= trilinear;
        sum += w * ddgi_sample_irradiance(vol, probe, n);
        wsum += w;
    }
#else
    {
        /* Masked lanes (common.glsl): weights first, then the visibility rays from one call
         * site; the trace inlined in each of eight unrolled corners cost lavapipe's probe
         * shading 2.2x (cornell+gltf, the paper's first hit only: 490 against 230 ms an
         * update). */
        float w[8]; /* 0: inactive */
        uint rays = 0u;
        [[dont_unroll]] for (uint i = 0u; i < 8u; i++) {
            bool ray;
            w[i] = ddgi_corner_weight(vol, mode, ddgi_corner_probe(vol, base, i), p, n, biased,
                                      crossed, clear_sigmas, ray);
            if (ray) rays |= 1u << i;
        }
        while (rays != 0u) {
            uint i = findLSB(rays);
            rays &= rays - 1u;
            if (ddgi_corner_blocked(vol, scene, ddgi_corner_probe(vol, base, i), biased)) w[i] = 1e-6;
        }
        [[dont_unroll]] for (uint i = 0u; i < 8u; i++) {
            if (w[i] <= 0.0) continue;
            float wt = w[i] * ddgi_trilinear(alpha, i);
            sum += wt * ddgi_sample_irradiance(vol, ddgi_corner_probe(vol, base, i), n);
            wsum += wt;
        }
    }
#endif
    vec3 e = wsum > 0.0 ? PC_PI * sum / wsum : vec3(0.0);
    return mix(sky_e, e, fade);
}

/* The field's irradiance at the hit (p, n) of a secondary ray that left a surface of shading
 * normal n0 along l and met p after t (a near-field, reflection or continued probe path's ray):
 * ddgi_irradiance with v = -l, its bias along v cut to half the ray (never past the origin, see
 * above) and the rest of that bias along n0, into the space the origin's surface faces. A
 * near-field ray from a pixel beside a room's corner meets the other wall a centimetre away;
 * with the bias along v cut to half a centimetre alone, the point stayed on that wall beside
 * the corner, where the probes outside 5 cm walls passed the visibility test: a bright seam and
 * a bright spot along builtin:hard:thin-walls' corner (gone with the rest of the bias along n0,
 * which lies on the room's side of both walls). */
/* The direction v and reach ddgi_irradiance_at_hit passes (a caller that queries probe-ray hits
 * and path hits from one call site picks between these and (-l, 1e30)). */
void ddgi_hit_view(pc_ddgi_volume vol, vec3 l, float t, vec3 n0, out vec3 v, out float reach)
{
    float bias = DDGI_VIEW_BIAS * vol.params.y;
    float back = min(bias, 0.5 * t);
    vec3 w = -l * back + n0 * (bias - back);
    reach = length(w);
    v = reach > 0.0 ? w / reach : -l;
}

vec3 ddgi_irradiance_at_hit(pc_ddgi_volume vol, pc_scene_refs scene, bool probe_hit, vec3 sky_e,
                            vec3 p, vec3 n, vec3 l, float t, vec3 n0, float clear_sigmas)
{
    vec3 v;
    float reach;
    ddgi_hit_view(vol, l, t, n0, v, reach);
    return ddgi_irradiance(vol, scene, probe_hit, sky_e, p, n, v, reach, clear_sigmas);
}

#endif
