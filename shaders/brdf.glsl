/* brdf.glsl: the one BRDF of the renderer: glTF 2.0 metallic-roughness as the glTF 2.0
 * specification's Appendix B (BRDF implementation) defines it, with its sampling for the
 * path tracer and the Lambertian stand-in used at DDGI probe-ray hits. Pure maths: no scene
 * access. Every pass (shade, ddgi_shade, ddgi_sample, pathtrace) reaches the material through
 * these functions, so no constant or formula exists twice.
 *
 * Appendix B, with H = normalize(V + L):
 *   D        = alpha^2 / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2)           GGX, alpha = roughness^2
 *   Vis      = 0.5 / (N.L sqrt((N.V)^2 (1 - alpha^2) + alpha^2) +
 *                     N.V sqrt((N.L)^2 (1 - alpha^2) + alpha^2))     Smith height-correlated
 *   specular = Vis * D
 *   metal    = specular * (baseColor + (1 - baseColor) (1 - V.H)^5)
 *   dielectric = mix(baseColor / pi, specular, 0.04 + 0.96 (1 - V.H)^5)
 *   f        = mix(dielectric, metal, metallic)
 * Every term is at most what it replaces, so the directional albedo stays <= 1 (single
 * scattering: rough metals lose some energy, as in the specification).
 * Two additions, both documented where they are defined: roughness is clamped below at
 * PC_BRDF_MIN_ROUGHNESS (a perfect mirror would make D a delta no punctual light can hit), and
 * the dielectric Fresnel weight is scaled by `specular` (1 for glTF; 0 makes a pure
 * Lambertian, which procedural scenes and the analytic tests use).
 *
 * One energy budget for every shading path. Radiance leaving a surface toward v is
 *   L(v) = Le + sum over lights f(v, l) E_light(l) + integral of f(v, l) L_i(l) (N.L) dl.
 * The direct term is always evaluated with the full f (brdf_eval), at camera pixels, probe-ray
 * hits and reflection hits alike. Appendix B's f = f_d + f_s splits into a diffuse part
 *   f_d = (1 - metallic) (1 - s F(V.H)) baseColor / pi
 * and a specular part f_s = F D Vis (F: the dielectric's s (0.04 + 0.96 w), the metal's
 * baseColor + (1 - baseColor) w, mixed by metallic; w = (1 - V.H)^5). The indirect integral is
 * carried in two parts and each part once:
 *   diffuse:  A_d(N.V) E(P, N) / pi, with A_d = brdf_diffuse_albedo_indirect (the directional
 *             albedo of f_d) and E the probe field's irradiance (DDGI);
 *   specular: camera pixels: reflect.comp (one GGX-sampled ray, unbiased) below
 *             PC_REFLECT_MAX_ROUGHNESS, else A_s(N.V) E(P, d) / pi (ddgi_sample.comp, d the
 *             lobe's dominant direction); probe-ray and reflection hits (secondary vertices):
 *             A_s(N.V) E(P, N) / pi, with A_s = brdf_specular_albedo, the directional albedo
 *             of f_s (single scattering, integrated by brdf_albedo.comp).
 * So a secondary hit reflects (A_d + A_s)(N.V) = brdf_hit_albedo of uniform light, exactly the
 * albedo the path tracer's f has at that view (at roughness 1, F0 0.04: A_s 0.012-0.021 and
 * A_d = 0.955-0.960 baseColor over N.V 1..0.5), and no Fresnel average is folded in twice.
 */
#ifndef PC_BRDF_GLSL
#define PC_BRDF_GLSL

#ifndef PC_PI
#define PC_PI 3.14159265358979323846
#endif
#define PC_BRDF_DIELECTRIC_F0 0.04
/* Perceptual roughness floor: alpha >= 0.002 keeps D and the VNDF sampler finite in fp32
 * (Filament uses the same 0.045). */
#define PC_BRDF_MIN_ROUGHNESS 0.045

struct pc_brdf {
    vec3 base;      /* linear base colour, 0..1 */
    float metallic; /* 0..1 */
    float alpha;    /* GGX alpha = clamped roughness^2 */
    float specular; /* weight of the dielectric specular lobe, 0..1 */
};

pc_brdf brdf_make(vec3 base, float metallic, float roughness, float specular)
{
    float r = clamp(roughness, PC_BRDF_MIN_ROUGHNESS, 1.0);
    return pc_brdf(clamp(base, 0.0, 1.0), clamp(metallic, 0.0, 1.0), r * r,
                   clamp(specular, 0.0, 1.0));
}

/* The albedo of the diffuse (Lambertian) lobe as the specification states it:
 * (1 - metallic) * baseColor. Multiplies indirect diffuse light (DDGI irradiance). */
vec3 brdf_diffuse_albedo(pc_brdf b) { return (1.0 - b.metallic) * b.base; }

float brdf_pow5(float x)
{
    float x2 = x * x;
    return x2 * x2 * x;
}

float brdf_ggx_d(float nh, float a2)
{
    float d = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (PC_PI * d * d);
}

/* Smith height-correlated visibility G2 / (4 N.L N.V) (Heitz 2014, eq. 99). */
float brdf_smith_vis(float nl, float nv, float a2)
{
    float gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
    float gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
    float sum = gv + gl;
    return sum > 0.0 ? 0.5 / sum : 0.0;
}

/* Smith G1 of GGX for the view direction (the VNDF's normalisation). */
float brdf_smith_g1(float nv, float a2)
{
    return 2.0 * nv / (nv + sqrt(a2 + (1.0 - a2) * nv * nv));
}

/* f(v, l) for unit n, v (toward the viewer) and l (toward the light); zero below the
 * shading surface. N.V is clamped to a small positive value (shading normals, normal maps
 * and interpolated normals can face slightly away from the viewer). */
vec3 brdf_eval(pc_brdf b, vec3 n, vec3 v, vec3 l)
{
    float nl = dot(n, l);
    if (nl <= 0.0) return vec3(0.0);
    float nv = clamp(dot(n, v), 1e-4, 1.0);
    vec3 hv = v + l;
    float hl = length(hv);
    vec3 h = hl > 1e-20 ? hv / hl : n;
    float nh = clamp(dot(n, h), 0.0, 1.0), vh = clamp(dot(v, h), 0.0, 1.0);
    float a2 = b.alpha * b.alpha;
    float spec = vh > 0.0 ? brdf_ggx_d(nh, a2) * brdf_smith_vis(min(nl, 1.0), nv, a2) : 0.0;
    float fw = brdf_pow5(1.0 - vh);
    float f_dielectric = b.specular * (PC_BRDF_DIELECTRIC_F0 + (1.0 - PC_BRDF_DIELECTRIC_F0) * fw);
    vec3 dielectric = mix(b.base / PC_PI, vec3(spec), f_dielectric);
    vec3 metal = spec * (b.base + (1.0 - b.base) * fw);
    return mix(dielectric, metal, b.metallic);
}

/* A rough estimate of the whole BRDF's albedo for the path tracer's choice of lobe only
 * (brdf_specular_probability; it changes variance, never the expected value):
 *   A = (1 - metallic) ((1 - s F_d) baseColor + s F_d) + metallic (baseColor + (1 - baseColor)/21)
 * with s = specular and F_d = 0.04 + 0.96/21, where 1/21 is the cosine-weighted hemispherical
 * average of (1 - cos)^5. It is NOT the energy a surface reflects: it counts the Fresnel
 * average as reflected although GGX at roughness 1 returns far less (0.012-0.021 against
 * F_d = 0.086). Shading uses brdf_hit_albedo (see the header). */
#define PC_BRDF_SCHLICK_AVG (1.0 / 21.0) /* 2 * integral of (1 - mu)^5 mu over [0, 1] */

/* s F_d: the dielectric lobe's Fresnel weight averaged over a Lambertian distribution. */
float brdf_dielectric_fresnel_avg(pc_brdf b)
{
    return b.specular * (PC_BRDF_DIELECTRIC_F0 + (1.0 - PC_BRDF_DIELECTRIC_F0) * PC_BRDF_SCHLICK_AVG);
}

vec3 brdf_lambert_albedo(pc_brdf b)
{
    const float avg = PC_BRDF_SCHLICK_AVG;
    float fd = brdf_dielectric_fresnel_avg(b);
    vec3 dielectric = (1.0 - fd) * b.base + fd;
    vec3 metal = b.base + (1.0 - b.base) * avg;
    return mix(dielectric, metal, b.metallic);
}

/* ---- sampling (path tracer) ------------------------------------------------------------ */

/* Orthonormal basis around n (Duff et al., JCGT 2017): columns t, bt, n. */
void brdf_basis(vec3 n, out vec3 t, out vec3 bt)
{
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float b = n.x * n.y * a;
    t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * b, -sign_z * n.x);
    bt = vec3(b, sign_z + n.y * n.y * a, -n.y);
}

/* Cosine-weighted direction around n (pdf cos / pi). */
vec3 brdf_sample_cosine(vec3 n, float u1, float u2)
{
    vec3 t, bt;
    brdf_basis(n, t, bt);
    float r = sqrt(u1), phi = 2.0 * PC_PI * u2;
    return normalize(t * (r * cos(phi)) + bt * (r * sin(phi)) + n * sqrt(max(0.0, 1.0 - u1)));
}

/* Probability of sampling the GGX lobe rather than the cosine lobe: the share of the
 * (Fresnel-averaged) specular albedo in the total, kept within [0.1, 0.9] when both lobes
 * exist so neither strategy starves; 0 for a pure Lambertian (then exactly the old
 * cosine-only sampler). */
float brdf_specular_probability(pc_brdf b)
{
    if (b.metallic <= 0.0 && b.specular <= 0.0) return 0.0;
    float fd = brdf_dielectric_fresnel_avg(b);
    float e_total = dot(brdf_lambert_albedo(b), vec3(1.0 / 3.0));
    float e_diffuse = dot((1.0 - b.metallic) * (1.0 - fd) * b.base, vec3(1.0 / 3.0));
    if (e_total <= 0.0) return 0.5;
    return clamp((e_total - e_diffuse) / e_total, 0.1, 0.9);
}

/* View direction in the local frame used for VNDF sampling and its pdf: below-horizon views
 * (possible with shading normals) are lifted to just above it, identically in both. */
vec3 brdf_local_view(vec3 n, vec3 t, vec3 bt, vec3 v)
{
    vec3 ve = vec3(dot(v, t), dot(v, bt), dot(v, n));
    ve.z = max(ve.z, 1e-4);
    return normalize(ve);
}

/* GGX visible-normal sampling (Heitz, "Sampling the GGX Distribution of Visible Normals",
 * JCGT 7(4) 2018, listing 1); ve in the local frame (z = n), returns the local microfacet
 * normal. */
vec3 brdf_sample_vndf(vec3 ve, float alpha, float u1, float u2)
{
    vec3 vh = normalize(vec3(alpha * ve.x, alpha * ve.y, ve.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(lensq) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u1), phi = 2.0 * PC_PI * u2;
    float p1 = r * cos(phi), p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(1e-6, nh.z)));
}

/* Solid-angle pdf of reflecting ve about a VNDF-sampled normal, for local l:
 * D_v(h) / (4 v.h) = G1(v) D(h) / (4 v.z). */
float brdf_pdf_vndf(vec3 ve, vec3 le, float alpha)
{
    vec3 h = normalize(ve + le);
    if (le.z <= 0.0 || dot(ve, h) <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    return brdf_smith_g1(ve.z, a2) * brdf_ggx_d(h.z, a2) / (4.0 * ve.z);
}

/* Samples a direction l for view v from the mixture p * VNDF-reflection + (1 - p) * cosine
 * (p = brdf_specular_probability; one-sample MIS with the balance heuristic, i.e. the
 * mixture pdf) and returns the weight f(v, l) cos / pdf_mixture(l), unbiased wherever f > 0
 * because the cosine lobe covers the hemisphere. u.z picks the lobe (unused when p is 0 or
 * 1). Returns false when l falls below the shading surface (the path ends). */
bool brdf_sample(pc_brdf b, vec3 n, vec3 v, vec3 u, out vec3 l, out vec3 weight)
{
    float p = brdf_specular_probability(b);
    vec3 t, bt;
    brdf_basis(n, t, bt);
    vec3 ve = brdf_local_view(n, t, bt, v);
    if (p > 0.0 && u.z < p) {
        vec3 h = brdf_sample_vndf(ve, b.alpha, u.x, u.y);
        vec3 le = reflect(-ve, h);
        l = normalize(t * le.x + bt * le.y + n * le.z);
    } else {
        l = brdf_sample_cosine(n, u.x, u.y);
    }
    vec3 le = vec3(dot(l, t), dot(l, bt), dot(l, n));
    float nl = le.z;
    weight = vec3(0.0);
    if (nl <= 0.0) return false;
    float pdf = (1.0 - p) * nl / PC_PI;
    if (p > 0.0) pdf += p * brdf_pdf_vndf(ve, le, b.alpha);
    if (!(pdf > 0.0)) return false;
    weight = brdf_eval(b, n, v, l) * nl / pdf;
    return true;
}

/* ---- indirect specular (reflect.comp, ddgi_sample.comp) ---------------------------------- */

/* Perceptual roughness of b (brdf_make stores alpha = roughness^2). */
float brdf_roughness(pc_brdf b) { return sqrt(b.alpha); }

/* Schlick F split as F = F0 (1 - w) + F90 w with w = (1 - V.H)^5, for the specular part of the
 * Appendix B mix: the dielectric lobe has F0 = 0.04 s, F90 = s; the metal F0 = baseColor,
 * F90 = 1; metallic blends the two. */
void brdf_fresnel_terms(pc_brdf b, out vec3 f0, out float f90)
{
    f0 = mix(vec3(b.specular * PC_BRDF_DIELECTRIC_F0), b.base, b.metallic);
    f90 = mix(b.specular, 1.0, b.metallic);
}

/* The specular lobe's directional albedo table (pc_globals.brdf_albedo, written once per
 * device by brdf_albedo.comp): entry j * PC_BRDF_ALBEDO_SIDE + i holds (A, B) at N.V = i / (side
 * - 1) and perceptual roughness j / (side - 1), with E = F0 A + F90 B the integral of
 * F(V.H) D Vis N.L over L. */
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer BrdfAlbedoRef { vec2 v[]; };

/* Directional albedo of the specular part of f for N.V = nv (bilinear in the table; the
 * entries are integrals of this very BRDF). Zero for a pure Lambertian. */
vec3 brdf_specular_albedo(uint64_t table, pc_brdf b, float nv)
{
    const int side = int(PC_BRDF_ALBEDO_SIDE);
    vec2 x = vec2(clamp(nv, 0.0, 1.0), clamp(brdf_roughness(b), 0.0, 1.0)) * float(side - 1);
    ivec2 i0 = min(ivec2(x), ivec2(side - 2));
    vec2 f = x - vec2(i0);
    int k = i0.y * side + i0.x;
    BrdfAlbedoRef t = BrdfAlbedoRef(table);
    vec2 ab = mix(mix(t.v[k], t.v[k + 1], f.x), mix(t.v[k + side], t.v[k + side + 1], f.x), f.y);
    vec3 f0;
    float f90;
    brdf_fresnel_terms(b, f0, f90);
    return f0 * ab.x + f90 * ab.y;
}

/* The diffuse albedo seen under indirect light from view N.V = nv once the specular part is
 * added separately: Appendix B weighs the dielectric's Lambertian by (1 - F(V.H)), so its
 * albedo is (1 - metallic) baseColor (1 - s (0.04 + 0.96 Phi(nv))) with Phi = the cosine-
 * weighted average over L of (1 - V.H)^5. Phi(nv) ~= 0.0271 (1 - nv)^2.44 fits numerical
 * integration within 4e-4 (0.021 at nv = 0.1, 0.005 at 0.5, 8e-5 at 1). Equals
 * brdf_diffuse_albedo exactly when s = 0. */
vec3 brdf_diffuse_albedo_indirect(pc_brdf b, float nv)
{
    float phi = 0.0271 * pow(clamp(1.0 - nv, 0.0, 1.0), 2.44);
    float f = b.specular * (PC_BRDF_DIELECTRIC_F0 + (1.0 - PC_BRDF_DIELECTRIC_F0) * phi);
    return brdf_diffuse_albedo(b) * (1.0 - f);
}

/* The directional albedo of the whole f for view N.V = nv, split into its diffuse part
 * (brdf_diffuse_albedo_indirect) and its specular part (brdf_specular_albedo, tabulated): what a
 * secondary hit (probe ray, reflection ray) reflects of the irradiance around it. Equals
 * brdf_diffuse_albedo for a pure Lambertian (s = 0, metallic = 0). See the header. */
vec3 brdf_hit_albedo(uint64_t table, pc_brdf b, float nv)
{
    return brdf_diffuse_albedo_indirect(b, nv) + brdf_specular_albedo(table, b, nv);
}

/* Samples the specular part of f alone by GGX visible normals (Heitz 2018): l = reflect(-v)
 * about the sampled microfacet normal, weight = F(V.H) G2 / G1(V), the unbiased estimate of
 * the specular part's integral against the incoming radiance along l (pdf D_v / (4 V.H),
 * f_spec N.L / pdf = F G2 / G1). False when l falls below the shading surface. */
bool brdf_sample_specular(pc_brdf b, vec3 n, vec3 v, vec2 u, out vec3 l, out vec3 weight)
{
    vec3 t, bt;
    brdf_basis(n, t, bt);
    vec3 ve = brdf_local_view(n, t, bt, v);
    vec3 h = brdf_sample_vndf(ve, b.alpha, u.x, u.y);
    vec3 le = reflect(-ve, h);
    l = normalize(t * le.x + bt * le.y + n * le.z);
    weight = vec3(0.0);
    if (le.z <= 0.0) return false;
    float a2 = b.alpha * b.alpha, nl = min(le.z, 1.0), nv = ve.z;
    float g2_over_g1 = 4.0 * nl * nv * brdf_smith_vis(nl, nv, a2) / brdf_smith_g1(nv, a2);
    vec3 f0;
    float f90;
    brdf_fresnel_terms(b, f0, f90);
    float w = brdf_pow5(1.0 - clamp(dot(ve, h), 0.0, 1.0));
    weight = (f0 * (1.0 - w) + f90 * w) * g2_over_g1;
    return true;
}

/* Direction whose neighbourhood carries most of a rough lobe's reflection: the mirror
 * direction pulled toward the normal as roughness grows (Lagarde & de Rousiers, "Moving
 * Frostbite to PBR", 2014, Sec. 4.9.3). */
vec3 brdf_dominant_direction(pc_brdf b, vec3 n, vec3 v)
{
    float r = brdf_roughness(b);
    float k = (1.0 - r) * (sqrt(1.0 - r) + r);
    return normalize(mix(n, reflect(-v, n), k));
}

#endif
