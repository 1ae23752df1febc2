/* common.glsl: scene access shared by every pass: buffer references, push constants,
 * texture sampling, surface reconstruction at a hit (materials, normal mapping),
 * punctual-light evaluation with the BRDF of brdf.glsl, and the trace routine (trace.glsl).
 * Passes include this file first. */
#ifndef PC_COMMON_GLSL
#define PC_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#include "gpu_types.h"

/* PC_MASKED_LANES 1: the variant for a device that runs a shader's branches under lane masks,
 * every branch and every loop at least once whether a lane takes it or not (lavapipe: LLVM code
 * over 8 lanes), so each inlined call site of a big routine costs its full price. The passes that
 * trace and shade (CMakeLists.txt: PC_MASKED_LANE_SHADERS) are compiled twice, and such calls
 * come from one site in a loop in this variant (the DDGI query's visibility rays, the probe path's
 * field query, a surface's textures, the alpha test: trace.glsl): a lavapipe probe update of
 * cornell+gltf at its default grid 1745 -> 1110 ms, the same image bit for bit. A GPU skips untaken branches, and
 * there the loops with their local arrays measured slower (NVIDIA H200, builtin:interior 1080p
 * gi sample 1.58 -> 1.71 ms): the 0 variant keeps the inlined calls. rd_pipelines_create picks
 * (rd_vk.masked_lanes); test_gpu_materials renders both variants and requires the same image. */
#ifndef PC_MASKED_LANES
#define PC_MASKED_LANES 0
#endif

#define PC_PI 3.14159265358979323846

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer GlobalsRef { pc_globals g; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriRef { pc_tri v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriAttrRef { pc_tri_attr v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer InstanceRef { pc_instance v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MaterialRef { pc_material v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TextureRef { pc_texture v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer TexelRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LightRef { pc_light v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer CounterRef { pc_counters c; };

layout(push_constant) uniform PushBlock { pc_push pc; };

pc_globals load_globals() { return GlobalsRef(pc.globals).g; }

/* ---- colour ---------------------------------------------------------------------------- */

vec3 srgb_to_linear(vec3 c)
{
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}

vec3 linear_to_srgb(vec3 c)
{
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

/* ---- textures: RGBA8 texels in one buffer, bilinear or nearest, glTF wrap modes ---------- */

int wrap_coord(int i, int n, uint mode)
{
    if (mode == PC_WRAP_CLAMP) return clamp(i, 0, n - 1);
    if (mode == PC_WRAP_MIRROR) {
        int period = 2 * n;
        int m = ((i % period) + period) % period;
        return m < n ? m : period - 1 - m;
    }
    return ((i % n) + n) % n;
}

vec4 texel_fetch(pc_scene_refs s, pc_texture t, int x, int y, bool srgb)
{
    int w = int(t.info.y), h = int(t.info.z);
    x = wrap_coord(x, w, t.info.w & 15u);
    y = wrap_coord(y, h, (t.info.w >> 4) & 15u);
    vec4 c = unpackUnorm4x8(TexelRef(s.texels).v[t.info.x + uint(y * w + x)]);
    return srgb ? vec4(srgb_to_linear(c.rgb), c.a) : c; /* filter in linear space */
}

/* Samples texture index (0-based) at uv. srgb: colour data (decoded to linear; alpha as
 * stored); else data as stored (metallic-roughness, normal and occlusion maps). */
vec4 sample_texture_as(pc_scene_refs s, uint index, vec2 uv, bool srgb)
{
    pc_texture t = TextureRef(s.textures).v[index];
    vec2 size = vec2(t.info.y, t.info.z);
    if (any(isnan(uv)) || any(isinf(uv))) uv = vec2(0.0);
    uv = uv - floor(uv / 4096.0) * 4096.0; /* keep float precision for huge repeats */
    vec2 p = uv * size - 0.5;
    if ((t.info.w & 0x100u) != 0u) {
        ivec2 ip = ivec2(floor(p + 0.5));
        return texel_fetch(s, t, ip.x, ip.y, srgb);
    }
    ivec2 i0 = ivec2(floor(p));
    vec2 f = p - vec2(i0);
    vec4 a = texel_fetch(s, t, i0.x, i0.y, srgb), b = texel_fetch(s, t, i0.x + 1, i0.y, srgb);
    vec4 c = texel_fetch(s, t, i0.x, i0.y + 1, srgb);
    vec4 d = texel_fetch(s, t, i0.x + 1, i0.y + 1, srgb);
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

vec4 sample_texture(pc_scene_refs s, uint index, vec2 uv) { return sample_texture_as(s, index, uv, true); }

vec2 tri_uv(pc_tri_attr a, float u, float v)
{
    return a.uv01.xy * (1.0 - u - v) + a.uv01.zw * u + a.uv2.xy * v;
}

/* Alpha-mask test used by trace.glsl for triangles flagged PC_TRI_ALPHA_MASK. */
#if PC_MASKED_LANES
/* Masked lanes (above) load every member of a struct read through a buffer reference, in every
 * triangle test, taken or not: this form reads only the words the test uses. */
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer Vec4Ref { vec4 v[]; };
bool trace_alpha_pass(pc_scene_refs s, uint tri, float u, float v)
{
    uint mat_index = floatBitsToUint(Vec4Ref(s.tris).v[tri * PC_TRI_VEC4S].w); /* v0.w */
    uint m = mat_index * PC_MATERIAL_VEC4S;
    Vec4Ref mat = Vec4Ref(s.materials);
    float alpha = mat.v[m].a; /* base_color.a */
    uint tex = floatBitsToUint(mat.v[m + PC_MATERIAL_TEX_VEC4].x);
    if (tex != 0u) {
        Vec4Ref attr = Vec4Ref(s.tri_attrs);
        uint a = tri * PC_TRI_ATTR_VEC4S;
        vec4 uv01 = attr.v[a + PC_TRI_ATTR_UV01_VEC4];
        vec2 uv = uv01.xy * (1.0 - u - v) + uv01.zw * u + attr.v[a + PC_TRI_ATTR_UV2_VEC4].xy * v;
        alpha *= sample_texture_as(s, tex - 1u, uv, false).a; /* alpha is linear either way */
    }
    return alpha >= mat.v[m + PC_MATERIAL_PARAMS_VEC4].x; /* params.x: the cutoff */
}
#else
bool trace_alpha_pass(pc_scene_refs s, uint tri, float u, float v)
{
    uint mat_index = floatBitsToUint(TriRef(s.tris).v[tri].v0.w);
    pc_material m = MaterialRef(s.materials).v[mat_index];
    float alpha = m.base_color.a;
    if (m.tex.x != 0u) {
        pc_tri_attr a = TriAttrRef(s.tri_attrs).v[tri];
        alpha *= sample_texture(s, m.tex.x - 1u, tri_uv(a, u, v)).a;
    }
    return alpha >= m.params.x;
}
#endif

#include "environment.glsl"
#include "trace.glsl"
#include "brdf.glsl"

/* ---- surfaces ---------------------------------------------------------------------------- */

struct pc_surface {
    vec3 position;    /* world */
    vec3 normal;      /* shading normal (normal-mapped), facing the incoming ray's origin side */
    vec3 geom_normal; /* geometric normal, same side */
    vec3 albedo;      /* linear base colour */
    vec3 emission;    /* emitted radiance (only from the front face or double-sided) */
    float metallic;   /* 0..1 */
    float roughness;  /* perceptual, 0..1 */
    float specular;   /* weight of the dielectric specular lobe (pc_material.params.w) */
    float occlusion;  /* ambient occlusion of indirect light, 1 = none */
    float offset;     /* rays leaving position move this far along geom_normal (trace.glsl) */
};

/* The surface's BRDF (brdf.glsl). */
pc_brdf surface_brdf(pc_surface sf)
{
    return brdf_make(sf.albedo, sf.metallic, sf.roughness, sf.specular);
}

vec3 xform_point(vec4 rows[3], vec3 p)
{
    vec4 h = vec4(p, 1.0);
    return vec3(dot(rows[0], h), dot(rows[1], h), dot(rows[2], h));
}

/* Direction transform: M v (no translation), with M given as rows. */
vec3 xform_vector(vec4 rows[3], vec3 v)
{
    return vec3(dot(rows[0].xyz, v), dot(rows[1].xyz, v), dot(rows[2].xyz, v));
}

vec3 octahedral_decode(uint bits)
{
    vec2 e = unpackSnorm2x16(bits);
    vec3 v = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (v.z < 0.0)
        v.xy = (1.0 - abs(v.yx)) * mix(vec2(-1.0), vec2(1.0), greaterThanEqual(v.xy, vec2(0.0)));
    return normalize(v);
}

/* Tangent-space normal map (glTF 2.0: +X along the tangent (increasing u), +Y along the
 * bitangent = cross(normal, tangent) * handedness, +Z along the normal). ns is the front-side
 * world shading normal. The object-space tangent T and bitangent B come from the TANGENT
 * attribute, or (without one) from the triangle's UV gradient: T = dp/du and B = -dp/dv (glTF's
 * v runs down the image, so "up" in the map is -v). Both are carried to world space by the
 * object-to-world matrix and made orthonormal against ns, which makes mirrored instances and
 * mirrored UVs right without a separate handedness rule. Returns ns when the frame is
 * degenerate. */
vec3 apply_normal_map(pc_material m, pc_tri t, pc_tri_attr a, pc_instance inst, pc_hit hit,
                      vec4 texel, vec3 ns)
{
    float w = 1.0 - hit.u - hit.v;
    vec3 T, B;
    if ((a.tangents.w & PC_TANGENT_PRESENT) != 0u) {
        vec3 t0 = octahedral_decode(a.tangents.x), t1 = octahedral_decode(a.tangents.y);
        vec3 t2 = octahedral_decode(a.tangents.z);
        float h0 = (a.tangents.w & PC_TANGENT_FLIP) != 0u ? -1.0 : 1.0;
        float h1 = (a.tangents.w & (PC_TANGENT_FLIP << 1)) != 0u ? -1.0 : 1.0;
        float h2 = (a.tangents.w & (PC_TANGENT_FLIP << 2)) != 0u ? -1.0 : 1.0;
        T = t0 * w + t1 * hit.u + t2 * hit.v;
        vec3 n_obj = a.n0.xyz * w + a.n1.xyz * hit.u + a.n2.xyz * hit.v;
        B = cross(n_obj, T) * (h0 * w + h1 * hit.u + h2 * hit.v >= 0.0 ? 1.0 : -1.0);
    } else {
        vec3 dp1 = t.v1.xyz - t.v0.xyz, dp2 = t.v2.xyz - t.v0.xyz;
        vec2 duv1 = a.uv01.zw - a.uv01.xy, duv2 = a.uv2.xy - a.uv01.xy;
        float det = duv1.x * duv2.y - duv2.x * duv1.y;
        if (abs(det) < 1e-20 || isnan(det)) return ns;
        T = (dp1 * duv2.y - dp2 * duv1.y) / det;
        B = -(dp2 * duv1.x - dp1 * duv2.x) / det;
    }
    T = xform_vector(inst.object_to_world, T);
    B = xform_vector(inst.object_to_world, B);
    T -= ns * dot(ns, T);
    float tl = length(T);
    if (!(tl > 1e-20) || isinf(tl)) return ns;
    T /= tl;
    B -= ns * dot(ns, B) + T * dot(T, B);
    float bl = length(B);
    if (!(bl > 1e-20) || isinf(bl)) return ns;
    B /= bl;
    vec3 tn = texel.xyz * 2.0 - 1.0;
    tn.xy *= m.params.y;
    vec3 n = T * tn.x + B * tn.y + ns * tn.z;
    float nl = length(n);
    return nl > 1e-20 && !isinf(nl) ? n / nl : ns;
}

/* Normal transform: (M^-1)^T n, with M^-1 given as rows. */
vec3 xform_normal(vec4 inv_rows[3], vec3 n)
{
    return inv_rows[0].xyz * n.x + inv_rows[1].xyz * n.y + inv_rows[2].xyz * n.z;
}

float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }

/* The magnitudes a ray leaving a point p (world) of triangle t of instance inst meets
 * (trace.glsl, ray_offset_distance): the triangle's local vertices scaled by the transform's
 * norm (the rebuilt position, and the triangle test's vertices minus origin), the transform's
 * translation (the way into the world and back) and p itself. */
float ray_offset_scale(pc_instance inst, pc_tri t, vec3 p)
{
    vec3 v = max(abs(t.v0.xyz), max(abs(t.v1.xyz), abs(t.v2.xyz)));
    vec4 r0 = abs(inst.object_to_world[0]), r1 = abs(inst.object_to_world[1]);
    vec4 r2 = abs(inst.object_to_world[2]);
    float norm = max(r0.x + r0.y + r0.z, max(r1.x + r1.y + r1.z, r2.x + r2.y + r2.z));
    return norm * max3(v) + max(r0.w, max(r1.w, r2.w)) + max3(abs(p));
}

/* Moves p (world), the hit at barycentrics (u, v) of triangle t of instance inst, into the
 * triangle where it lies nearer than `offset` (world) to an edge: along each such edge's inward
 * normal in the triangle's plane, by what it lacks of that distance (at most 3 offsets in all;
 * triangles whose incircle is narrower than 2 offsets are left alone). A hit on the edge where two
 * walls meet at a concave corner lies on (or rounds past) the other wall's plane, and the ray
 * offset along its own normal keeps it there: rays from it would leave the room through the
 * corner. Moved inward by the offset, it lies inside both walls. Points away from the edges keep
 * their exact barycentric position. */
void keep_off_edges(pc_tri t, pc_instance inst, float u, float v, float offset, inout vec3 p)
{
    vec3 e1 = xform_vector(inst.object_to_world, t.v1.xyz - t.v0.xyz); /* v0 -> v1 */
    vec3 e2 = xform_vector(inst.object_to_world, t.v2.xyz - t.v0.xyz); /* v0 -> v2 */
    vec3 n = cross(e1, e2);
    float area2 = length(n);
    /* the edges opposite v0, v1, v2, counter-clockwise about n: cross(n, edge) points inward */
    vec3 a = e2 - e1, b = -e2, c = e1;
    vec3 len = vec3(length(a), length(b), length(c));
    /* distance of p from each edge: its barycentric times the height over that edge */
    vec3 dist = vec3(1.0 - u - v, u, v) * area2 / len;
    vec3 lack = max(vec3(offset) - dist, vec3(0.0));
    /* offset * perimeter / area2 = offset / the incircle's radius */
    if (!(area2 > 0.0) || isinf(area2) || offset * (len.x + len.y + len.z) > 0.5 * area2 ||
        all(equal(lack, vec3(0.0))))
        return;
    vec3 move = cross(n, a) * (lack.x / len.x) + cross(n, b) * (lack.y / len.y) +
                cross(n, c) * (lack.z / len.z);
    p += move / area2;
}

/* Rebuilds the surface at a hit. The geometric normal is the object-space front normal
 * carried by the inverse transpose, so a mirroring node (negative determinant) keeps the
 * front side glTF gives it (the winding flips with the determinant); both normals are then
 * turned toward the side the ray came from. The position keeps off the triangle's edges by the
 * ray offset (keep_off_edges). */
pc_surface surface_at(pc_scene_refs s, pc_hit hit, vec3 ray_dir)
{
    pc_surface sf;
    pc_tri t = TriRef(s.tris).v[hit.tri];
    pc_tri_attr a = TriAttrRef(s.tri_attrs).v[hit.tri];
    pc_instance inst = InstanceRef(s.instances).v[hit.instance];
    float w = 1.0 - hit.u - hit.v;
    vec3 p_obj = t.v0.xyz * w + t.v1.xyz * hit.u + t.v2.xyz * hit.v;
    sf.position = xform_point(inst.object_to_world, p_obj);
    sf.offset = ray_offset_distance(ray_offset_scale(inst, t, sf.position));
    keep_off_edges(t, inst, hit.u, hit.v, sf.offset, sf.position);

    vec3 ng = xform_normal(inst.world_to_object, cross(t.v1.xyz - t.v0.xyz, t.v2.xyz - t.v0.xyz));
    float ng_len = length(ng);
    ng = ng_len > 0.0 && !isinf(ng_len) ? ng / ng_len : -ray_dir;
    vec3 ns = xform_normal(inst.world_to_object, a.n0.xyz * w + a.n1.xyz * hit.u + a.n2.xyz * hit.v);
    float ns_len = length(ns);
    ns = ns_len > 1e-20 && !isinf(ns_len) && !isnan(ns_len) ? ns / ns_len : ng;
    if (dot(ns, ng) < 0.0) ns = -ns; /* vertex normals authored against the winding */

    uint mat_index = floatBitsToUint(t.v0.w);
    pc_material m = MaterialRef(s.materials).v[mat_index];
    vec2 uv = tri_uv(a, hit.u, hit.v);
    /* The material's textures: base colour and emission (sRGB; emission only where its factor
     * emits), normal map, metallic-roughness and occlusion (linear). With masked lanes they are
     * fetched first, from one call site (five inlined samplers cost lavapipe's probe shading of
     * untextured scenes 13%); else each where it is used. */
#if PC_MASKED_LANES
    vec4 texels[5] = vec4[5](vec4(1.0), vec4(1.0), vec4(1.0), vec4(1.0), vec4(1.0));
    uint ids[5] = uint[5](m.tex.x, any(greaterThan(m.emission.rgb, vec3(0.0))) ? m.tex.y : 0u,
                          m.tex2.y, m.tex2.x, m.tex2.z);
    uint pending = 0u; /* one bit per texture the material has */
    for (uint k = 0u; k < 5u; k++)
        if (ids[k] != 0u) pending |= 1u << k;
    while (pending != 0u) {
        uint k = findLSB(pending);
        pending &= pending - 1u;
        texels[k] = sample_texture_as(s, ids[k] - 1u, uv, k < 2u);
    }
#define SURFACE_TEXEL(k, index, srgb) texels[k]
#else
#define SURFACE_TEXEL(k, index, srgb) sample_texture_as(s, (index) - 1u, uv, srgb)
#endif
    if (m.tex2.y != 0u) {
        ns = apply_normal_map(m, t, a, inst, hit, SURFACE_TEXEL(2, m.tex2.y, false), ns);
        /* keep the mapped normal on the front side of the true surface */
        float c = dot(ns, ng);
        if (c < 0.01) ns = normalize(ns + ng * (0.01 - c));
    }
    bool facing_away = dot(ng, ray_dir) > 0.0;
    if (facing_away) {
        ng = -ng;
        ns = -ns;
    }
    sf.normal = ns;
    sf.geom_normal = ng;

    vec3 albedo = m.base_color.rgb;
    if (m.tex.x != 0u) albedo *= SURFACE_TEXEL(0, m.tex.x, true).rgb;
    vec3 emission = m.emission.rgb;
    if (m.tex.y != 0u && any(greaterThan(emission, vec3(0.0))))
        emission *= SURFACE_TEXEL(1, m.tex.y, true).rgb;
    bool double_sided = m.tex.w != 0u;
    sf.albedo = clamp(albedo, 0.0, 1.0);
    sf.emission = (!hit.backface || double_sided) ? max(emission, vec3(0.0)) : vec3(0.0);
    sf.metallic = m.pbr.x;
    sf.roughness = m.pbr.y;
    if (m.tex2.x != 0u) { /* glTF: B = metalness, G = roughness, linear */
        vec4 mr = SURFACE_TEXEL(3, m.tex2.x, false);
        sf.metallic *= mr.b;
        sf.roughness *= mr.g;
    }
    sf.specular = m.params.w;
    sf.occlusion = 1.0;
    if (m.tex2.z != 0u) /* glTF: occlusion = 1 + strength * (R - 1) */
        sf.occlusion = 1.0 + m.params.z * (SURFACE_TEXEL(4, m.tex2.z, false).r - 1.0);
#undef SURFACE_TEXEL
    sf.metallic = clamp(sf.metallic, 0.0, 1.0);
    sf.roughness = clamp(sf.roughness, 0.0, 1.0);
    sf.occlusion = clamp(sf.occlusion, 0.0, 1.0);
    return sf;
}

/* The BRDF of a G-buffer texel (pc_gbuffer_texel.material: metallic, roughness, occlusion,
 * specular weight). */
pc_brdf gbuffer_brdf(pc_gbuffer_texel t)
{
    return brdf_make(t.albedo.rgb, t.material.x, t.material.y, t.material.w);
}

/* Whether a G-buffer texel has a specular part at all, and whether it traces reflection rays
 * (glossy: perceptual roughness below PC_REFLECT_MAX_ROUGHNESS); see gpu_types.h. */
bool gbuffer_has_specular(pc_gbuffer_texel t)
{
    return t.position.w >= 0.0 && (t.material.x > 0.0 || t.material.w > 0.0);
}
bool gbuffer_traces_reflection(pc_gbuffer_texel t)
{
    return gbuffer_has_specular(t) && t.material.y < PC_REFLECT_MAX_ROUGHNESS;
}

/* ---- punctual lights (KHR_lights_punctual) --------------------------------------------- */

/* Direction toward the light, distance to it (1e30 for directional) and the irradiance it
 * delivers on a surface facing it (before the cosine term and visibility). */
vec3 light_incident(pc_light l, vec3 p, out vec3 wi, out float dist)
{
    if (l.info.x == PC_LIGHT_DIRECTIONAL) {
        wi = -l.direction.xyz;
        dist = 1e30;
        return l.radiance.rgb;
    }
    vec3 d = l.position_range.xyz - p;
    float d2 = dot(d, d);
    dist = sqrt(d2);
    wi = dist > 0.0 ? d / dist : vec3(0.0, 0.0, 1.0);
    float atten = 1.0 / max(d2, 1e-12);
    float range = l.position_range.w;
    if (range > 0.0) {
        float r = dist / range;
        atten *= clamp(1.0 - r * r * r * r, 0.0, 1.0);
    }
    if (l.info.x == PC_LIGHT_SPOT)
        atten *= smoothstep(l.spot.x, l.spot.y, dot(l.direction.xyz, -wi));
    return l.radiance.rgb * atten;
}

/* The unshadowed term f * E * cos of light i at p (zero when the light lies below the shading or
 * the geometric surface), its direction and distance. */
vec3 light_term(pc_scene_refs s, uint i, vec3 p, vec3 n, vec3 ng, vec3 v, pc_brdf b, out vec3 wi,
                out float dist)
{
    vec3 e = light_incident(LightRef(s.lights).v[i], p, wi, dist);
    float cos_n = dot(n, wi);
    if (cos_n <= 0.0 || dot(ng, wi) <= 0.0) return vec3(0.0);
    return brdf_eval(b, n, v, wi) * e * cos_n;
}

/* A shadow ray from origin (a surface point already offset along its geometric normal, on the
 * light's side) toward a light at distance dist along wi: true when nothing blocks it. Counts
 * the ray into rays. */
bool shadow_ray_clear(pc_scene_refs s, vec3 origin, vec3 wi, float dist, inout uint rays)
{
    pc_hit sh;
    rays++;
    return !trace_ray(s, origin, wi, 0.0, dist, PC_TRACE_ANY_HIT, sh);
}

/* The light choice of direct_radiance_sampled: light i is chosen with probability
 * p_i = w_i / W, w_i the summed RGB of its unshadowed term f E_i cos (lights below the surfaces
 * weigh 0), W their sum. Returns its index (PC_INVALID when no light reaches p) with its
 * unshadowed term divided by p_i (term), its direction and its distance. u: uniform in [0, 1).
 * One pass over the lights, each term evaluated once (a weighted reservoir of one): light i
 * takes the choice with probability w_i / (w_0 + ... + w_i), which leaves each light chosen with
 * w_i / W. The one number u decides every step: rescaled to [0, 1) within the part of it the
 * step used, it stays uniform and independent of the choices so far. (The inverse CDF needs W
 * first: a second pass of every light's BRDF, 10% of lavapipe's probe shading of cornell+gltf.)
 * One light: the same choice and term as W / w_0 = 1. */
uint choose_light(pc_scene_refs s, vec3 p, vec3 n, vec3 ng, vec3 v, pc_brdf b, float u,
                  out vec3 term, out vec3 wi, out float dist)
{
    term = vec3(0.0);
    wi = vec3(0.0);
    dist = 0.0;
    float total = 0.0, chosen_w = 0.0;
    uint chosen = PC_INVALID;
    for (uint i = 0u; i < s.counts.y; i++) {
        vec3 l_wi;
        float l_dist;
        vec3 f = light_term(s, i, p, n, ng, v, b, l_wi, l_dist);
        float w = f.r + f.g + f.b;
        if (!(w > 0.0)) continue;
        total += w;
        float q = w / total; /* 1 for the first light with weight */
        if (u < q) {
            chosen = i;
            term = f;
            chosen_w = w;
            wi = l_wi;
            dist = l_dist;
            u /= q;
        } else {
            u = (u - q) / (1.0 - q);
        }
        u = min(max(u, 0.0), 0.99999994); /* rounding may leave [0, 1) */
    }
    if (chosen == PC_INVALID) return PC_INVALID;
    term *= total / chosen_w;
    return chosen;
}

/* The sum of direct_radiance estimated with at most ONE shadow ray, toward the light that
 * choose_light picks; its shadowed term divided by p_i. Unbiased (E[result] equals
 * direct_radiance), and exactly direct_radiance when at most one light reaches p. Probe hits use
 * the choice (ddgi_shade.comp): their shadow rays are most of an update's cost and grow with the
 * light count, while a probe texel averages hundreds of rays over many updates, which absorbs
 * the selection noise. */
vec3 direct_radiance_sampled(pc_scene_refs s, vec3 p, vec3 n, vec3 ng, float offset, vec3 v,
                             pc_brdf b, float u, inout uint rays)
{
    vec3 term, wi;
    float dist;
    if (choose_light(s, p, n, ng, v, b, u, term, wi, dist) == PC_INVALID) return vec3(0.0);
    return shadow_ray_clear(s, offset_ray_origin(p, ng, offset), wi, dist, rays) ? term
                                                                                  : vec3(0.0);
}

/* Ray counting with one global atomic per workgroup. Every invocation of the workgroup must
 * call both (no early return in between). which: 0 primary, 1 shadow, 2 probe, 3 path,
 * 4 probe shadow, 5 reflection, 6 shadow map, 7 probe path, 8 near field. */
shared uint pc_wg_rays;
void count_rays_begin()
{
    if (gl_LocalInvocationIndex == 0u) pc_wg_rays = 0u;
    barrier();
}
void count_rays_end(uint64_t counters, uint which, uint rays)
{
    if (rays != 0u) atomicAdd(pc_wg_rays, rays);
    barrier();
    if (gl_LocalInvocationIndex == 0u && pc_wg_rays != 0u && counters != 0ul) {
        CounterRef c = CounterRef(counters);
        if (which == 0u) atomicAdd(c.c.primary_rays, pc_wg_rays);
        else if (which == 1u) atomicAdd(c.c.shadow_rays, pc_wg_rays);
        else if (which == 2u) atomicAdd(c.c.probe_rays, pc_wg_rays);
        else if (which == 3u) atomicAdd(c.c.path_rays, pc_wg_rays);
        else if (which == 4u) atomicAdd(c.c.probe_shadow_rays, pc_wg_rays);
        else if (which == 5u) atomicAdd(c.c.reflect_rays, pc_wg_rays);
        else if (which == 6u) atomicAdd(c.c.shadow_map_rays, pc_wg_rays);
        else if (which == 7u) atomicAdd(c.c.probe_path_rays, pc_wg_rays);
        else atomicAdd(c.c.near_rays, pc_wg_rays);
    }
}

/* PCG hash (Jarzynski & Olano, JCGT 2020): random streams of the stochastic passes. */
uint pcg(uint v)
{
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

/* Next uniform number in [0, 1) of stream s. */
float rnd(inout uint s)
{
    s = pcg(s);
    return float(s >> 8) * (1.0 / 16777216.0);
}

/* Camera ray through the picture point uv (normalised: 0..1 across, 0..1 down from the top
 * row). The primary pass and the pick route (pick.comp) share it. */
vec3 camera_dir_at(pc_view v, vec2 uv)
{
    vec2 ndc = vec2(2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y);
    return normalize(v.forward.xyz + ndc.x * v.right.xyz + ndc.y * v.up.xyz);
}

/* Camera ray through the centre of pixel (x, y); y = 0 is the top row. */
vec3 camera_dir(pc_view v, uvec2 px)
{
    return camera_dir_at(v, (vec2(px) + 0.5) / vec2(v.size.xy));
}
#endif
