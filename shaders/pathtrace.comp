#version 460
/* Reference path tracer: one path per pixel per dispatch, accumulated in a float buffer.
 * Unbiased for our material model (Lambertian + emission, punctual lights): the camera ray
 * goes through the pixel centre (the same point DDGI shades, so errors compare per pixel);
 * every vertex adds emission (emitters are reached only by BSDF sampling, so no MIS is
 * needed) and next-event estimation of every punctual light with a shadow ray; directions
 * are cosine-weighted (throughput *= albedo); Russian roulette from bounce 3 on with
 * survival max(throughput) capped at 0.95, no clamping. Back faces of single-sided
 * surfaces absorb (the same convention as DDGI's probe rays). Deterministic per seed.
 * push: globals, buf0 = vec4 accumulation[], buf1 = pc_counters,
 *       params.x = sample index, params.y = max bounces (0 = 64). */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(local_size_x = PC_WG_2D_X, local_size_y = PC_WG_2D_Y) in;
layout(buffer_reference, std430, buffer_reference_align = 16) buffer AccumRef { vec4 v[]; };

/* PCG hash (Jarzynski & Olano, JCGT 2020). */
uint pcg(uint v)
{
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float rnd(inout uint s)
{
    s = pcg(s);
    return float(s >> 8) * (1.0 / 16777216.0);
}

/* Cosine-weighted direction around n (Duff et al. 2017 orthonormal basis). */
vec3 sample_cosine(vec3 n, float u1, float u2)
{
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * b, -sign_z * n.x);
    vec3 bt = vec3(b, sign_z + n.y * n.y * a, -n.y);
    float r = sqrt(u1), phi = 2.0 * PC_PI * u2;
    return normalize(t * (r * cos(phi)) + bt * (r * sin(phi)) + n * sqrt(max(0.0, 1.0 - u1)));
}

void main()
{
    count_rays_begin();
    pc_globals g = load_globals();
    uvec2 px = gl_GlobalInvocationID.xy;
    uint rays = 0u;
    if (all(lessThan(px, g.view.size.xy))) {
        uint pixel = px.y * g.view.size.x + px.x;
        uint s = pcg(pixel ^ pcg(pc.params.x ^ pcg(g.view.size.w)));
        uint max_bounces = pc.params.y == 0u ? 64u : pc.params.y;
        vec3 org = g.view.eye.xyz, dir = camera_dir(g.view, px);
        vec3 throughput = vec3(1.0), radiance = vec3(0.0);
        uint flags = PC_TRACE_CULL_BACKFACES; /* primary rays see what the camera sees */
        for (uint bounce = 0u; bounce <= max_bounces; bounce++) {
            pc_hit hit;
            rays++;
            if (!trace_ray(g.scene, org, dir, 0.0, 1e30, flags, hit)) {
                radiance += throughput * env_radiance(g.env, dir);
                break;
            }
            flags = 0u;
            pc_surface sf = surface_at(g.scene, hit, dir);
            if (hit.backface) {
                uint tf = floatBitsToUint(TriRef(g.scene.tris).v[hit.tri].v1.w);
                if ((tf & PC_TRI_DOUBLE_SIDED) == 0u) break; /* absorbed */
            }
            radiance += throughput * sf.emission;
            uint shadow = 0u;
            vec3 e = direct_irradiance(g.scene, sf.position, sf.normal, sf.geom_normal, shadow);
            rays += shadow;
            radiance += throughput * sf.albedo / PC_PI * e;
            if (bounce == max_bounces) break;
            throughput *= sf.albedo;
            if (bounce >= 3u) {
                float q = min(0.95, max(throughput.r, max(throughput.g, throughput.b)));
                if (rnd(s) >= q) break;
                throughput /= q;
            }
            if (all(equal(throughput, vec3(0.0)))) break;
            float u1 = rnd(s), u2 = rnd(s);
            dir = sample_cosine(sf.normal, u1, u2);
            if (dot(dir, sf.geom_normal) <= 0.0) break; /* below the true surface */
            org = offset_ray_origin(sf.position, sf.geom_normal);
        }
        AccumRef acc = AccumRef(pc.buf0);
        acc.v[pixel] = (pc.params.x == 0u ? vec4(0.0) : acc.v[pixel]) + vec4(radiance, 1.0);
    }
    count_rays_end(pc.buf1, 3u, rays);
}
