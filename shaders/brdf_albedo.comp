#version 460
/* Directional albedo table of the GGX specular lobe of brdf.glsl (glTF 2.0 Appendix B: GGX D,
 * Smith height-correlated visibility, Schlick F), for the indirect specular term
 * (brdf_specular_albedo): with F = F0 (1 - w) + F90 w, w = (1 - V.H)^5,
 *   A = integral of D Vis (1 - w) N.L dL,   B = integral of D Vis w N.L dL,
 * at N.V = i / (side - 1) and perceptual roughness j / (side - 1), one invocation per entry.
 * Integrated with the renderer's own VNDF sampler (brdf_sample_vndf), whose weight per
 * sample is G2 / G1, on a stratified PC_BRDF_ALBEDO_SAMPLES^2 grid: the table is the integral
 * of exactly the BRDF the path tracer samples, with no second copy of any formula. Runs once
 * per device (rd_view_passes_create); a few million samples.
 * push: buf0 = vec2 table[PC_BRDF_ALBEDO_SIDE^2]. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_1D) in;
layout(buffer_reference, std430, buffer_reference_align = 8) writeonly buffer TableRef { vec2 v[]; };

void main()
{
    const uint side = PC_BRDF_ALBEDO_SIDE, n = PC_BRDF_ALBEDO_SAMPLES;
    uint e = gl_GlobalInvocationID.x;
    if (e >= side * side) return;
    float nv = max(float(e % side) / float(side - 1u), 1e-4);
    pc_brdf b = brdf_make(vec3(1.0), 1.0, float(e / side) / float(side - 1u), 1.0);
    float a2 = b.alpha * b.alpha;
    vec3 ve = vec3(sqrt(1.0 - nv * nv), 0.0, nv);
    vec2 sum = vec2(0.0);
    for (uint i = 0u; i < n; i++)
        for (uint j = 0u; j < n; j++) {
            vec2 u = (vec2(i, j) + 0.5) / float(n);
            vec3 h = brdf_sample_vndf(ve, b.alpha, u.x, u.y);
            vec3 le = reflect(-ve, h);
            if (le.z <= 0.0) continue;
            float nl = min(le.z, 1.0);
            float g = 4.0 * nl * nv * brdf_smith_vis(nl, nv, a2) / brdf_smith_g1(nv, a2);
            float w = brdf_pow5(1.0 - clamp(dot(ve, h), 0.0, 1.0));
            sum += g * vec2(1.0 - w, w);
        }
    TableRef(pc.buf0).v[e] = sum / float(n * n);
}
