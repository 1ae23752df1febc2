/* gpu_types.h: every struct, constant and workgroup size that crosses the CPU/GPU boundary.
 *
 * Compiled by both C11 and glslang. GLSL sources define PC_GLSL before including it.
 * Layout rules: scalars, vec4/uvec4 only (no vec3, no mat3, no enums, no bool);
 * the std430 layout of every struct equals its C layout, and the C side checks
 * sizes and member offsets with _Static_assert below.
 *
 * All scene and frame data is reached through buffer device addresses (uint64_t),
 * so no descriptor sets are needed and no single binding is limited by
 * maxStorageBufferRange (128 MiB on lavapipe).
 */
#ifndef PC_GPU_TYPES_H
#define PC_GPU_TYPES_H

#ifdef PC_GLSL
#define PC_STRUCT(name) struct name
#define PC_END(name)
#define pc_vec4 vec4
#define pc_uvec4 uvec4
#define pc_u32 uint
#define pc_f32 float
#define pc_u64 uint64_t
#else
#include <stddef.h>
#include <stdint.h>
typedef struct pc_vec4 {
    float x, y, z, w;
} pc_vec4;
typedef struct pc_uvec4 {
    uint32_t x, y, z, w;
} pc_uvec4;
typedef uint32_t pc_u32;
typedef float pc_f32;
typedef uint64_t pc_u64;
#define PC_STRUCT(name) typedef struct name
#define PC_END(name) name
#include <string.h>
/* The C side of GLSL's floatBitsToUint / uintBitsToFloat, for indices kept in w components. */
static inline uint32_t pc_f2u(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}
static inline float pc_u2f(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}
#endif

/* ---- workgroup sizes ------------------------------------------------------------------- */
#define PC_WG_2D_X 8
#define PC_WG_2D_Y 8
#define PC_WG_1D 64
/* The GPU BVH builder's constants (LBVH and PLOC): shaders/bvh_build_types.h. */

/* ---- enumerations (plain constants: GLSL has no enums) ------------------------------- */
#define PC_LIGHT_POINT 0u
#define PC_LIGHT_SPOT 1u
#define PC_LIGHT_DIRECTIONAL 2u

#define PC_ALPHA_OPAQUE 0u
#define PC_ALPHA_MASK 1u
#define PC_ALPHA_BLEND 2u /* drawn as opaque (no transparency): see renderer/gltf/gltf_loader.h */

#define PC_WRAP_REPEAT 0u
#define PC_WRAP_CLAMP 1u
#define PC_WRAP_MIRROR 2u

/* pc_tri.v1.w flag bits (stored as uint bits) */
#define PC_TRI_DOUBLE_SIDED 1u
#define PC_TRI_ALPHA_MASK 2u

/* trace() flags */
#define PC_TRACE_ANY_HIT 1u        /* stop at the first accepted hit (shadow rays) */
#define PC_TRACE_CULL_BACKFACES 2u /* ignore back faces of single-sided materials (primary rays)   \
                                    */

#define PC_TONEMAP_ACES 0u
#define PC_TONEMAP_CLAMP 1u

#define PC_VIEW_FINAL 0u      /* direct + indirect */
#define PC_VIEW_IRRADIANCE 1u /* indirect irradiance only (E / pi, as if albedo were 1) */
#define PC_VIEW_PROBES 2u     /* final image with probe spheres showing their irradiance */

/* Indirect specular (shaders/reflect.comp, renderer/view.c). Pixels whose material has a
 * specular part (metallic > 0 or a dielectric specular weight > 0) and a perceptual roughness
 * below PC_REFLECT_MAX_ROUGHNESS trace one GGX-sampled reflection ray per frame; rougher ones
 * take the probe field's irradiance around the lobe's dominant direction (ddgi_sample.comp).
 * 0.6 (alpha 0.36): the lobe of a rougher surface spans most of the hemisphere, where
 * E(r)/pi of the cosine-convolved probe field is close to the lobe's average radiance (the
 * split-sum error shrinks with roughness), while below it highlights of the scene itself
 * (windows, emitters, objects) are visible in the reflection and need a ray. */
#define PC_REFLECT_MAX_ROUGHNESS 0.6
#define PC_REFLECT_AUTO 0u /* rd_view_settings.reflections: wherever a material is glossy */
#define PC_REFLECT_OFF 1u  /* no indirect specular at all (the renderer before reflections) */
/* Temporal accumulation: a running average over at most this many frames while the view and
 * the world stay the same (then an exponential average of that length, which follows the
 * probe field as it converges). */
#define PC_REFLECT_HISTORY_MAX 64u
/* The specular lobe's directional albedo table (shaders/brdf_albedo.comp): entries per side
 * (N.V and roughness) and stratified samples per side of each entry's integral. Bilinear
 * lookups stay within 1.1% of the integral for metals and 2% for dielectrics (N.V >= 0.05). */
#define PC_BRDF_ALBEDO_SIDE 16u
#define PC_BRDF_ALBEDO_SAMPLES 64u
/* Spatial filter radius in pixels at roughness PC_REFLECT_MAX_ROUGHNESS (none below 0.1). */
#define PC_REFLECT_FILTER_RADIUS 3

/* Near-field rays (shaders/near_field.comp, renderer/view.c): the probe field cannot hold light
 * that varies faster than its spacing (a room's corners, contacts under objects, the inside of
 * a lamp shade), so camera pixels trace short cosine-sampled rays, PC_NEAR_REACH times the
 * smallest probe spacing long, and keep per pixel the mean ratio of the irradiance they find
 * (hits shaded, misses taken as the field's) to the field's irradiance. One pixel of each 2x2
 * block traces per frame (PC_NEAR_INTERLEAVE frames visit all four); the history holds at most
 * PC_NEAR_HISTORY_MAX samples per pixel, then averages exponentially over that length (it
 * follows the field as it converges). A view settles after PC_NEAR_SETTLE_FRAMES frames of one
 * history epoch; later frames of that epoch trace nothing and reuse the history, unless the
 * probe field is still converging (it keeps tracing then, and the field's falling asleep starts
 * a new epoch; so do changes of lights, nodes, camera or settings). Ratios are clamped to PC_NEAR_RATIO_MAX (a sample of a small, very bright hit
 * would otherwise stay visible as a speck). */
#define PC_NEAR_AUTO 0u /* rd_view_settings.near_field: near-field rays wherever GI is on */
#define PC_NEAR_OFF 1u  /* the probe field alone (the renderer before near-field rays) */
#define PC_NEAR_REACH 0.5
#define PC_NEAR_INTERLEAVE 4u
#define PC_NEAR_HISTORY_MAX 16u
#define PC_NEAR_SETTLE_FRAMES (PC_NEAR_INTERLEAVE * PC_NEAR_HISTORY_MAX)
#define PC_NEAR_RATIO_MAX 8.0

/* Shadow rays of camera pixels and reflection hits (rd_view_settings.shadow_cull): camera
 * pixels trace none toward a light whose distance map shows the point certainly hidden
 * (shaders/shadow_map.glsl, direct_radiance with DIRECT_CULLED_RAYS) and reflection hits read
 * each light's map where its texels agree (DIRECT_MAP_VISIBILITY); or a ray to every light in
 * front of either (exact everywhere, also behind openings narrower than a map texel). */
#define PC_SHADOW_CULL_MAPS 0u
#define PC_SHADOW_CULL_OFF 1u

/* Rays leave surfaces moved along the geometric normal by PC_RAY_OFFSET_REL times the
 * magnitudes the hit's arithmetic met (shaders/trace.glsl, ray_offset_distance): with their sum
 * about twice the largest, that is 2^-15 of it, Wächter and Binder's 256 ulps. */
#define PC_RAY_OFFSET_REL (1.0 / 65536.0)
#define PC_RAY_OFFSET_MIN 1.0e-30

#define PC_BVH_STACK_SIZE 64
#define PC_INVALID 0xffffffffu

/* ---- scene geometry ------------------------------------------------------------------ */

/* One triangle of a bottom-level BVH, in object space, in BVH leaf order.
 * v0.w: material index (uint bits); v1.w: PC_TRI_* flags (uint bits);
 * v2.w: index of the triangle in its mesh before reordering (uint bits). */
PC_STRUCT(pc_tri)
{
    pc_vec4 v0;
    pc_vec4 v1;
    pc_vec4 v2;
}
PC_END(pc_tri);
#define PC_TRI_VEC4S 3u /* pc_tri read as vec4s (trace_alpha_pass with masked lanes) */

/* Shading attributes of the triangle with the same index as in the pc_tri array.
 * n0..n2: object-space vertex normals (xyz); uv01 = (u0, v0, u1, v1); uv2 = (u2, v2, -, -);
 * tangents: the mesh's TANGENT attribute, x/y/z = vertex 0/1/2's object-space tangent as
 * octahedral unit vectors (packSnorm2x16 bits), w = flag bits: PC_TANGENT_PRESENT, and
 * PC_TANGENT_FLIP << k when vertex k has handedness -1. Without PC_TANGENT_PRESENT the
 * tangent frame comes from the triangle's UVs (shaders/common.glsl). */
PC_STRUCT(pc_tri_attr)
{
    pc_vec4 n0;
    pc_vec4 n1;
    pc_vec4 n2;
    pc_vec4 uv01;
    pc_vec4 uv2;
    pc_uvec4 tangents;
}
PC_END(pc_tri_attr);
#define PC_TRI_ATTR_VEC4S 6u /* pc_tri_attr read as vec4s: uv01 and uv2 are vec4s 3 and 4 */
#define PC_TRI_ATTR_UV01_VEC4 3u
#define PC_TRI_ATTR_UV2_VEC4 4u
#define PC_TANGENT_PRESENT 8u
#define PC_TANGENT_FLIP 1u

/* BVH node (bottom and top level). bmin.w and bmax.w hold uint bits:
 * count = bmax.w; count == 0: interior node, children at index bmin.w and bmin.w + 1;
 * count  > 0: leaf with primitives [bmin.w, bmin.w + count) (triangles for a BLAS,
 * entries of the TLAS instance index array for the TLAS). Indices are absolute. */
PC_STRUCT(pc_bvh_node)
{
    pc_vec4 bmin;
    pc_vec4 bmax;
}
PC_END(pc_bvh_node);

/* A placed mesh. Affine transforms stored as three rows (x' = dot(row0, vec4(p, 1)) ...).
 * info.x: root node of the mesh's BLAS (absolute), info.y: mesh index, info.z: 0,
 * info.w: scene node index. Front faces are decided in object space: glTF flips the
 * winding of a mirroring (negative-determinant) node, which keeps the object's front side. */
PC_STRUCT(pc_instance)
{
    pc_vec4 object_to_world[3];
    pc_vec4 world_to_object[3];
    pc_uvec4 info;
}
PC_END(pc_instance);

/* glTF 2.0 metallic-roughness material (BRDF: shaders/brdf.glsl).
 * base_color: linear factor (a = alpha factor); emission: rgb = emissiveFactor * strength;
 * tex.x/y: base colour / emissive texture index + 1 (0 = none); tex.z: PC_ALPHA_*;
 * tex.w: 1 if double sided; params: x alpha cutoff, y normalTexture scale, z occlusionTexture
 * strength, w weight of the dielectric specular lobe (1: glTF, 0: pure Lambertian);
 * pbr: x metallicFactor, y roughnessFactor, z/w unused;
 * tex2.x/y/z: metallic-roughness / normal / occlusion texture index + 1 (0 = none). */
PC_STRUCT(pc_material)
{
    pc_vec4 base_color;
    pc_vec4 emission;
    pc_uvec4 tex;
    pc_vec4 params;
    pc_vec4 pbr;
    pc_uvec4 tex2;
}
PC_END(pc_material);
#define PC_MATERIAL_VEC4S 6u /* pc_material read as vec4s: base_color, tex and params are 0, 2, 3 */
#define PC_MATERIAL_TEX_VEC4 2u
#define PC_MATERIAL_PARAMS_VEC4 3u

/* An RGBA8 texture (sRGB-encoded colour, linear alpha) in the texel array.
 * info.x: first texel (one uint per texel, R in the low byte), info.y: width, info.z: height,
 * info.w: wrap_s | wrap_t << 4 | nearest << 8. */
PC_STRUCT(pc_texture)
{
    pc_uvec4 info;
}
PC_END(pc_texture);

/* KHR_lights_punctual light in world space.
 * position_range: xyz position, w = range (0 = unlimited);
 * direction_type: xyz = direction the light shines toward (unit), w unused;
 * radiance: rgb = colour * intensity (candela for point/spot, lux for directional);
 * spot: x = cos(outer cone angle), y = cos(inner cone angle); info.x: PC_LIGHT_*. */
PC_STRUCT(pc_light)
{
    pc_vec4 position_range;
    pc_vec4 direction;
    pc_vec4 radiance;
    pc_vec4 spot;
    pc_uvec4 info;
}
PC_END(pc_light);

/* Addresses and counts of the scene on the GPU. */
PC_STRUCT(pc_scene_refs)
{
    pc_u64 tris;       /* pc_tri[]            */
    pc_u64 tri_attrs;  /* pc_tri_attr[]       */
    pc_u64 blas_nodes; /* pc_bvh_node[]       */
    pc_u64 tlas_nodes; /* pc_bvh_node[]       */
    pc_u64 tlas_index; /* uint[]: TLAS leaf entry -> instance index */
    pc_u64 instances;  /* pc_instance[]       */
    pc_u64 materials;  /* pc_material[]       */
    pc_u64 textures;   /* pc_texture[]        */
    pc_u64 texels;     /* uint[]              */
    pc_u64 lights;     /* pc_light[]          */
    pc_uvec4 counts;   /* x: instances, y: lights, z: materials, w: textures */
}
PC_END(pc_scene_refs);

/* Camera and output settings for one frame of one view.
 * eye: xyz position; forward/right/up: camera basis scaled so that a pixel's direction is
 * forward + ndc.x * right + ndc.y * up with ndc in [-1, 1] (y up);
 * size: x width, y height, z frame index, w seed;
 * tonemap: x exposure scale (2^EV), y PC_TONEMAP_* as float, z PC_VIEW_* as float. */
PC_STRUCT(pc_view)
{
    pc_vec4 eye;
    pc_vec4 forward;
    pc_vec4 right;
    pc_vec4 up;
    pc_uvec4 size;
    pc_vec4 tonemap;
}
PC_END(pc_view);

/* What the world around the scene looks like; shared by every view of a world
 * (renderer/env/environment.h, shaders/environment.glsl).
 * sky: rgb uniform radiance, or the gradient's zenith radiance; w: image intensity;
 * ground: rgb the gradient's nadir radiance; w: image rotation about +y (radians);
 * irradiance: SH9 coefficients (rgb) of the cosine-convolved radiance, for probe fallbacks;
 * image: equirectangular texels, RGBA16F as two uints each, row 0 at the zenith (0: none);
 * mode: PC_ENV_*; width, height: of the image. */
#define PC_ENV_UNIFORM 0u
#define PC_ENV_GRADIENT 1u
#define PC_ENV_IMAGE 2u
PC_STRUCT(pc_environment)
{
    pc_vec4 sky;
    pc_vec4 ground;
    pc_vec4 irradiance[9];
    pc_u64 image;
    pc_u32 mode;
    pc_u32 width;
    pc_u32 height;
    pc_u32 pad0;
    pc_u32 pad1;
    pc_u32 pad2;
}
PC_END(pc_environment);

/* ---- DDGI probe volume (Majercik et al. 2019) -------------------------------------------- */
#define PC_GI_OFF 0u
#define PC_GI_CLASSIC 1u /* irradiance probes, trilinear weights only (the paper's baseline) */
#define PC_GI_DDGI 2u    /* + back-face wrap, Chebyshev visibility, weight crush */

#define PC_DDGI_IRR_INTERIOR 8u   /* irradiance texels per side, without border */
#define PC_DDGI_DIST_INTERIOR 16u /* distance texels per side, without border */
#define PC_DDGI_MAX_RAYS 1024u
#define PC_DDGI_IRR_TEXELS (PC_DDGI_IRR_INTERIOR * PC_DDGI_IRR_INTERIOR)
#define PC_DDGI_WEIGHT_TEXELS (PC_DDGI_IRR_TEXELS + PC_DDGI_DIST_INTERIOR * PC_DDGI_DIST_INTERIOR)
/* The update's blend weights (ddgi_weights.comp): uint counts[PC_DDGI_WEIGHT_TEXELS], then from
 * byte PC_DDGI_WEIGHT_HEADER uvec2 (ray, weight bits) entries, texel t's k-th at
 * k * PC_DDGI_WEIGHT_TEXELS + t (neighbouring texels' k-th entries side by side: a warp of the
 * blend reads one run of memory) */
#define PC_DDGI_WEIGHT_HEADER (PC_DDGI_WEIGHT_TEXELS * 4u)
/* Probe states (probes[].w, as a float; 2021 follow-up paper, Sec. 5). Bit 0 (ACTIVE) means
 * shading samples the probe; bit 1 means its value is final and updates skip it. */
#define PC_DDGI_PROBE_ACTIVE 1u   /* bit: outside geometry, sampled */
/* Where the irradiance query traces visibility rays (ddgi.glsl, issue 28): where geometry
 * crosses a cage edge between two active probes (a wall thinner than the spacing), one ray to
 * each of them, at probe-ray hits and camera pixels and reflection hits (ALL, the default), at
 * probe-ray hits only (PROBES), or nowhere (OFF: Chebyshev's test alone, as in the paper). */
#define PC_DDGI_VIS_ALL 0u
#define PC_DDGI_VIS_PROBES 1u
#define PC_DDGI_VIS_OFF 2u
#define PC_DDGI_PROBE_OFF 0u      /* inside geometry: not sampled; re-checked now and then */
#define PC_DDGI_PROBE_AWAKE 1u    /* sampled, traced and blended every update */
#define PC_DDGI_PROBE_SLEEPING 3u /* converged: sampled, neither traced nor blended */
/* An off probe traces only this many of its rays, enough to notice when the geometry around
 * it changes (2021 paper: off probes trace a few fixed rays), and is neither shaded nor
 * blended; it is traced once every PC_DDGI_OFF_RECHECK updates, or after a wake in its box. */
#define PC_DDGI_INACTIVE_RAYS 32u
/* Probe relocation (2021 follow-up paper; RTXGI 1.3 limits moves to 45% of a cell): during the
 * first PC_DDGI_RELOCATE_BLENDS blends after a reset or a geometry wake, a probe inside geometry
 * moves through its nearest back face, and one closer than PC_DDGI_RELOCATE_CLEARANCE spacings
 * to a front face moves away from it, to that clearance; a move that would take its offset past
 * PC_DDGI_RELOCATE_LIMIT of the spacing on any axis is not made (the probe stays where it is, off
 * if inside). The clearance stays below the default grid's margin (0.15 spacings,
 * renderer/gi/ddgi.c), so the default layers next to a room's walls do not move. Off by default
 * (setting probe_relocation): tests/bench/results/h200/relocation.txt. */
#define PC_DDGI_RELOCATE_BLENDS 4u
#define PC_DDGI_RELOCATE_CLEARANCE 0.1
#define PC_DDGI_RELOCATE_LIMIT 0.45
/* Probe-hit bins for sorted shading (ddgi_bin.comp): a PC_DDGI_BIN_SIDE^3 grid over the probe
 * volume. */
#define PC_DDGI_BIN_SIDE 16u
#define PC_DDGI_BINS (PC_DDGI_BIN_SIDE * PC_DDGI_BIN_SIDE * PC_DDGI_BIN_SIDE)
#define PC_DDGI_OFF_RECHECK 16u
/* Adaptive hysteresis: a probe of age a (updates since it was woken, counted only while the
 * awake field shows no drift) blends with h = min(h_max, a / (a + PC_DDGI_AGE_RAMP)), and
 * falls asleep PC_DDGI_SETTLE_UPDATES updates after h reached h_max. A probe's age holds for
 * at most PC_DDGI_HOLD_FACTOR times the sleep age since its last wake, so every probe sleeps
 * within (1 + PC_DDGI_HOLD_FACTOR) sleep ages. Rule and measurements: renderer/gi/ddgi.c.
 * Wake events set the age of the probes they reach to at most: */
#define PC_DDGI_AGE_RAMP 4.0
#define PC_DDGI_SETTLE_UPDATES 16u
#define PC_DDGI_HOLD_FACTOR 3u
#define PC_DDGI_WAKE_AGE_GEOMETRY 0.0 /* a node moved: start over (h = 0) */
#define PC_DDGI_WAKE_AGE_LIGHT 4.0    /* a light or the sky changed: h = 0.5 at first */
#define PC_DDGI_WAKE_AGE_NUDGE 23.0   /* one small step of an animated light: h = 0.85 */
#define PC_DDGI_WAKE_MAX 32u          /* wake boxes per update; more become "wake all" */
/* Lights' distance maps for the direct light at probe-ray hits (renderer/gi/shadow_maps.h,
 * shaders/shadow_map.glsl): a point or spot light has a cube of 6 faces of SIDE^2 float
 * texels, each the distance from the light to the first surface along the texel's centre
 * direction; a directional light has one SUN_SIDE^2 orthographic map over the scene's bounding
 * sphere. Lights past MAX_LIGHTS keep shadow rays. Header layout: shaders/shadow_map.glsl. */
#define PC_SHADOW_MAP_SIDE 128u
#define PC_SHADOW_MAP_BOXES 32u /* boxes of moved geometry a partial rebuild re-traces */
#define PC_SHADOW_MAP_SUN_SIDE 1024u
#define PC_SHADOW_MAP_MAX_LIGHTS 256u
/* The maps buffer's header (words): offsets, build orders, the suns' frame and box count, the
 * boxes; the maps follow. */
#define PC_SHADOW_MAP_FRAME_WORD (2u * PC_SHADOW_MAP_MAX_LIGHTS)
#define PC_SHADOW_MAP_BOX_WORD (PC_SHADOW_MAP_FRAME_WORD + 8u)
#define PC_SHADOW_MAP_HEADER_WORDS (PC_SHADOW_MAP_BOX_WORD + 8u * PC_SHADOW_MAP_BOXES)
/* What a build does with a light's map (the header's build orders)... */
#define PC_SHADOW_MAP_KEEP 0u  /* nothing: it is valid, or it waits (its hits trace rays) */
#define PC_SHADOW_MAP_WHOLE 1u /* trace every texel */
#define PC_SHADOW_MAP_PART 2u  /* re-trace the texels whose rays cross a box of moved geometry */
/* ...and the build's dispatches (push params.x): whole cubes, whole suns' squares, one
 * rectangle of a map ordered PART (face PC_SHADOW_MAP_SUN_FACE: a sun's square) */
#define PC_SHADOW_MAP_PASS_CUBES 0u
#define PC_SHADOW_MAP_PASS_SUNS 1u
#define PC_SHADOW_MAP_PASS_RECT 2u
#define PC_SHADOW_MAP_SUN_FACE 6u
#define PC_DDGI_DRIFT_RANGE 0x3fffffffu /* the drift sums' fixed point: |sum| <= this */
/* Irradiance texels hold (E / pi)^(1/e), blended in that space; readers raise the stored value
 * to the e-th power (pc_ddgi_volume.encoding). e = 5 is the paper's perceptual encoding, kept
 * while probe rays end at their first hit (probe_paths 0). With continued probe paths e = 1:
 * the encoding averages the fifth roots of the fresh values, so a texel whose fresh values are
 * noisy (rare rays that meet a small bright patch: the inside of a lamp shade, a sunlit strip)
 * settles well below their mean (Jensen's inequality); it left builtin:interior -14..-19% with
 * the paths where the linear blend leaves -4..-9% (tests/bench/results/h200/probe_paths.txt).
 * Half floats need no encoding for range or precision. The linear blend is not the default with
 * first-hit rays: there the encoding's darkening hides the leaks of thin walls and contacts
 * (hard:thin-walls +2.8% against -4.0%, the lavapipe Cornell test's relMSE 0.14 against 0.12). */
#define PC_DDGI_ENCODING_PAPER 5 /* ddgi.glsl decodes it with multiplies */

/* origin: xyz position of probe (0,0,0), w = max ray distance for distance blending;
 * spacing: xyz grid spacing, w = PC_DDGI_VIS_* (as float);
 * counts: xyz probes per axis, w = rays per probe;
 * rotation: rows of this update's random ray rotation (uniform on SO(3));
 * params: x maximum hysteresis, y bias scale (world units), z back-face ratio that deactivates
 *   a probe, w fixed-point units per unit of stored (encoded) luminance in the drift sums (set
 *   by the CPU each update);
 * info: x PC_GI_*, y updates done since reset (0 = next is the first), z atlas irradiance
 *   tile side (interior + 2), w distance tile side (interior + 2);
 * control: x = 1 while the awake field drifts (ages hold), y = age at which a probe falls
 *   asleep (as float bits), z = wake boxes this update, w unused;
 * irradiance: uvec2[] per texel (packHalf2x16 of (E / pi)^(1/encoding) and a written flag);
 * distance: vec2[] per texel (mean, mean of squares);
 * rays: vec4[] per probe ray (radiance, hit distance; < 0: back face);
 * probes: vec4[] per probe (xyz offset, w = PC_DDGI_PROBE_* state as float);
 * stats: vec4[] per probe (x age, y updates its age held since its last wake, z bits 0-2: geometry
 *   crosses the segment to the +x, +y, +z neighbour (ddgi_select.comp), w = 1 when an off probe
 *   must be re-checked);
 * list: uint[] probes updated this update (written by ddgi_select.comp);
 * ctrl: pc_ddgi_control (host-visible: indirect dispatch sizes, census, drift sums);
 * wake: pc_ddgi_wake[control.z] boxes (host-visible);
 * weights: the update's blend weights per tile texel (ddgi_weights.comp; layout at
 *   PC_DDGI_WEIGHT_HEADER);
 * order: uint[counts.w], the ray each thread of a probe traces and shades: the rays sorted so
 *   that a warp's rays point into one patch of the sphere (renderer/gi/ddgi.c). Their hits lie
 *   close together and their shadow rays toward a light run side by side, which the GPU
 *   traverses far faster than scattered rays. */
PC_STRUCT(pc_ddgi_volume)
{
    pc_vec4 origin;
    pc_vec4 spacing;
    pc_uvec4 counts;
    pc_vec4 rotation[3];
    pc_vec4 params;
    pc_uvec4 info;
    pc_u64 irradiance;
    pc_u64 distance;
    pc_u64 rays;
    pc_u64 probes;
    pc_uvec4 control; /* x hold, y sleep age (float bits), z wake boxes this update, w lights
                         [0, w) read their distance maps at probe hits (0: shadow rays only) */
    pc_u64 stats;
    pc_u64 list;
    pc_u64 ctrl;
    pc_u64 wake;
    pc_u64 order;
    pc_u64 shadow_maps; /* float[]: the lights' distance maps (renderer/gi/shadow_maps.h); 0: none */
    pc_u64 weights;
    pc_u32 relocate;    /* 1: probes move out of geometry and off surfaces (ddgi_blend.glsl) */
    pc_u32 blend_lists; /* 1: the irradiance blend walks the weight lists (a CPU device), 0: the
                           hemisphere's run of rays (a GPU; ddgi_blend.glsl says why) */
    pc_u32 path_bounces; /* bounces a probe ray's path takes before the field ends it (0: the
                            paper's first hit; ddgi_shade.comp) */
    pc_u32 encoding;     /* irradiance texels hold (E / pi)^(1/encoding): PC_DDGI_ENCODING_PAPER
                            or 1 (linear, with path_bounces > 0) */
    pc_u32 pad0, pad1;
}
PC_END(pc_ddgi_volume);

/* One update's bookkeeping, reset by the CPU before each update and read back after it. */
PC_STRUCT(pc_ddgi_control)
{
    pc_uvec4 trace_args;  /* indirect dispatch: x ray groups, y listed probes, z 1 */
    pc_uvec4 blend_args;  /* x listed probes, y 1, z 1 */
    pc_uvec4 border_args; /* x border groups per probe, y listed probes, z 1 */
    pc_uvec4 before;      /* states when the update began: x awake, y sleeping, z off, w listed */
    pc_uvec4 after;       /* states the listed probes ended in: x awake, y sleeping, z off */
    pc_uvec4 drift;       /* stored (encoded) luminance of the blended probes' tiles, fixed point (int):
                             x sum of the gap the blend closed (step of the stored value over
                             1 - h), y sum of stored, both over probes that had a stored value,
                             z their count, w sum of fresh over all */
    pc_uvec4 shade_args;  /* sorted probe shading: x groups, y 1, z 1, w rays (ddgi_scan.comp) */
}
PC_END(pc_ddgi_control);

/* A wake event: probes within [lo, hi] (GPU frame) get age at most lo.w. */
PC_STRUCT(pc_ddgi_wake)
{
    pc_vec4 lo;
    pc_vec4 hi;
}
PC_END(pc_ddgi_wake);

/* Everything a pass reads, in one GPU buffer reached by address. scene, env and ddgi are the
 * world's (rd_world_fill_globals); view is the rendering view's (zero for probe updates);
 * brdf_albedo: the device's specular albedo table (vec2[PC_BRDF_ALBEDO_SIDE^2], brdf.glsl's
 * brdf_specular_albedo; set by views, 0 for probe updates). */
PC_STRUCT(pc_globals)
{
    pc_scene_refs scene;
    pc_view view;
    pc_ddgi_volume ddgi;
    pc_environment env;
    pc_u64 brdf_albedo;
    pc_u64 pad;
}
PC_END(pc_globals);

/* Per-pixel surface record written by the primary pass.
 * position: xyz world position, w = hit distance (< 0: miss);
 * normal: xyz shading normal facing the viewer, w = instance index (uint bits);
 * geom_normal: xyz geometric normal facing the viewer, w = triangle index (uint bits);
 * albedo: rgb base colour (linear), w = the ray offset of the hit (pc_surface.offset: how far
 * rays leaving it move along geom_normal; 0 for a miss); emission: rgb emitted radiance;
 * material: x metallic, y roughness (perceptual), z ambient occlusion (1 = none), w weight of
 * the dielectric specular lobe (pc_material.params.w). The shading normal is normal-mapped. */
PC_STRUCT(pc_gbuffer_texel)
{
    pc_vec4 position;
    pc_vec4 normal;
    pc_vec4 geom_normal;
    pc_vec4 albedo;
    pc_vec4 emission;
    pc_vec4 material;
}
PC_END(pc_gbuffer_texel);

/* Ray counters incremented by the passes (read back for --timings). */
PC_STRUCT(pc_counters)
{
    pc_u32 primary_rays;
    pc_u32 shadow_rays; /* from camera-visible surfaces */
    pc_u32 probe_rays;
    pc_u32 path_rays;         /* path-traced rays, shadow rays included */
    pc_u32 probe_shadow_rays; /* from probe-ray hits and their paths' vertices */
    pc_u32 reflect_rays;      /* reflection rays of camera pixels and their shadow rays */
    pc_u32 shadow_map_rays;   /* rays that built lights' distance maps */
    pc_u32 probe_path_rays;   /* bounce rays of the paths that probe-ray hits continue */
    pc_u32 near_rays;         /* near-field rays of camera pixels and their shadow rays */
    pc_u32 pad0, pad1, pad2;
}
PC_END(pc_counters);

/* A view's reflection bookkeeping for one frame (host visible; reset by the CPU before the
 * frame, written by primary.comp). args: indirect dispatch of the reflection passes: x = width
 * groups when some visible pixel traces reflections, else 0 (nothing runs), y = height groups,
 * z = 1; w = number of such pixels. */
PC_STRUCT(pc_reflect_control)
{
    pc_uvec4 args;
}
PC_END(pc_reflect_control);

/* The answer of the pick pass (shaders/pick.comp): one camera ray through a picture point.
 * position: xyz world position of the hit (shifted by the floating origin), w = distance from
 * the eye; normal: xyz geometric normal facing the eye, w unused; info: x = 1 for a hit (0: a
 * miss, nothing else set), y = instance index, z = triangle index (BVH leaf order), w unused. */
PC_STRUCT(pc_pick_result)
{
    pc_vec4 position;
    pc_vec4 normal;
    pc_uvec4 info;
}
PC_END(pc_pick_result);

/* Push constants of deform.comp (renderer/accel/gpu_deform.c): the flat per-vertex arrays of one
 * deforming mesh (uploaded once), the pose (joint matrices, 16 floats each, column-major, and
 * morph weights; uploaded per pose) and the outputs. An address of 0: that array is absent.
 * counts: x vertices, y influences per vertex (0, 4 or 8), z morph targets, w joints. */
PC_STRUCT(pc_deform_push)
{
    pc_uvec4 counts;         /* first: a uvec4 sits on 16 bytes */
    pc_u64 rest_positions;   /* 3 floats per vertex */
    pc_u64 rest_normals;     /* 3 floats per vertex */
    pc_u64 rest_tangents;    /* 4 floats per vertex */
    pc_u64 joints;           /* `influences` uints per vertex */
    pc_u64 weights;          /* `influences` floats per vertex */
    pc_u64 target_positions; /* 3 floats per vertex and target, target-major */
    pc_u64 target_normals;
    pc_u64 target_tangents;
    pc_u64 joint_mats;    /* 16 floats per joint */
    pc_u64 morph_weights; /* one float per target */
    pc_u64 out_positions; /* 3 floats per vertex */
    pc_u64 out_normals;   /* 3 floats per vertex */
    pc_u64 out_tangents;  /* 4 floats per vertex */
}
PC_END(pc_deform_push);

/* Push constants shared by all passes: address of pc_globals plus pass-specific words. */
PC_STRUCT(pc_push)
{
    pc_u64 globals; /* pc_globals  */
    pc_u64 buf0;    /* pass-specific buffers */
    pc_u64 buf1;
    pc_u64 buf2;
    pc_uvec4 params;
}
PC_END(pc_push);

#ifndef PC_GLSL
#define PC_CHECK(type, size) _Static_assert(sizeof(type) == (size), #type " size")
#define PC_OFF(type, member, off)                                                                  \
    _Static_assert(offsetof(type, member) == (off), #type "." #member " offset")
PC_CHECK(pc_tri, 48);
PC_OFF(pc_tri, v1, 16);
PC_OFF(pc_tri, v2, 32);
PC_CHECK(pc_tri_attr, 96);
PC_OFF(pc_tri_attr, uv01, 48);
PC_OFF(pc_tri_attr, uv2, 64);
PC_OFF(pc_tri_attr, tangents, 80);
PC_CHECK(pc_bvh_node, 32);
PC_OFF(pc_bvh_node, bmax, 16);
PC_CHECK(pc_instance, 112);
PC_OFF(pc_instance, world_to_object, 48);
PC_OFF(pc_instance, info, 96);
PC_CHECK(pc_material, 96);
PC_OFF(pc_material, emission, 16);
PC_OFF(pc_material, tex, 32);
PC_OFF(pc_material, params, 48);
PC_OFF(pc_material, pbr, 64);
PC_OFF(pc_material, tex2, 80);
/* the vec4 views of trace_alpha_pass (shaders/common.glsl, masked lanes) */
PC_CHECK(pc_tri, PC_TRI_VEC4S * 16);
PC_CHECK(pc_tri_attr, PC_TRI_ATTR_VEC4S * 16);
PC_OFF(pc_tri_attr, uv01, PC_TRI_ATTR_UV01_VEC4 * 16);
PC_OFF(pc_tri_attr, uv2, PC_TRI_ATTR_UV2_VEC4 * 16);
PC_CHECK(pc_material, PC_MATERIAL_VEC4S * 16);
PC_OFF(pc_material, tex, PC_MATERIAL_TEX_VEC4 * 16);
PC_OFF(pc_material, params, PC_MATERIAL_PARAMS_VEC4 * 16);
PC_CHECK(pc_texture, 16);
PC_CHECK(pc_light, 80);
PC_OFF(pc_light, direction, 16);
PC_OFF(pc_light, radiance, 32);
PC_OFF(pc_light, spot, 48);
PC_OFF(pc_light, info, 64);
PC_CHECK(pc_scene_refs, 96);
PC_OFF(pc_scene_refs, lights, 72);
PC_OFF(pc_scene_refs, counts, 80);
PC_CHECK(pc_view, 96);
PC_OFF(pc_view, size, 64);
PC_OFF(pc_view, tonemap, 80);
PC_CHECK(pc_environment, 208);
PC_OFF(pc_environment, image, 176);
PC_OFF(pc_environment, mode, 184);
PC_CHECK(pc_ddgi_volume, 256);
PC_OFF(pc_ddgi_volume, weights, 224);
PC_OFF(pc_ddgi_volume, control, 160);
PC_OFF(pc_ddgi_volume, wake, 200);
PC_OFF(pc_ddgi_volume, order, 208);
PC_OFF(pc_ddgi_volume, shadow_maps, 216);
PC_CHECK(pc_ddgi_control, 112);
PC_CHECK(pc_ddgi_wake, 32);
PC_OFF(pc_ddgi_volume, counts, 32);
PC_OFF(pc_ddgi_volume, rotation, 48);
PC_OFF(pc_ddgi_volume, params, 96);
PC_OFF(pc_ddgi_volume, info, 112);
PC_OFF(pc_ddgi_volume, irradiance, 128);
PC_OFF(pc_ddgi_volume, probes, 152);
PC_CHECK(pc_globals, 672);
PC_OFF(pc_globals, brdf_albedo, 656);
PC_OFF(pc_globals, view, 96);
PC_OFF(pc_globals, ddgi, 192);
PC_OFF(pc_globals, env, 448);
PC_CHECK(pc_gbuffer_texel, 96);
PC_OFF(pc_gbuffer_texel, albedo, 48);
PC_OFF(pc_gbuffer_texel, emission, 64);
PC_OFF(pc_gbuffer_texel, material, 80);
PC_CHECK(pc_counters, 48);
PC_OFF(pc_counters, probe_shadow_rays, 16);
PC_OFF(pc_counters, reflect_rays, 20);
PC_CHECK(pc_reflect_control, 16);
PC_CHECK(pc_pick_result, 48);
PC_OFF(pc_pick_result, normal, 16);
PC_OFF(pc_pick_result, info, 32);
PC_CHECK(pc_push, 48);
PC_OFF(pc_push, params, 32);
PC_CHECK(pc_deform_push, 120);
PC_OFF(pc_deform_push, rest_positions, 16);
PC_OFF(pc_deform_push, out_tangents, 112);
#undef PC_CHECK
#undef PC_OFF
#endif

#endif /* PC_GPU_TYPES_H */
