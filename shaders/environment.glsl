/* environment.glsl: the light from outside the scene (renderer/env/environment.h): radiance toward
 * a direction for rays that escape, and irradiance from its SH9 for probe fallbacks. The CPU
 * twins are rd_env_radiance and rd_env_irradiance_eval. Included by common.glsl. */
#ifndef PC_ENVIRONMENT_GLSL
#define PC_ENVIRONMENT_GLSL

layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer EnvTexelRef { uvec2 v[]; };

vec3 env_texel(pc_environment e, int x, int y)
{
    int w = int(e.width), h = int(e.height);
    x = ((x % w) + w) % w;
    y = clamp(y, 0, h - 1);
    uvec2 t = EnvTexelRef(e.image).v[y * w + x];
    return vec3(unpackHalf2x16(t.x), unpackHalf2x16(t.y).x);
}

/* Radiance arriving from direction d (unit; the direction the light travels is -d). */
vec3 env_radiance(pc_environment e, vec3 d)
{
    if (e.mode == PC_ENV_GRADIENT) return mix(e.ground.rgb, e.sky.rgb, 0.5 + 0.5 * d.y);
    if (e.mode != PC_ENV_IMAGE || e.image == 0ul) return e.sky.rgb;
    const float two_pi = 6.28318530717958647692;
    float u = atan(d.x, -d.z) / two_pi + 0.5 - e.ground.w / two_pi;
    float v = acos(clamp(d.y, -1.0, 1.0)) / 3.14159265358979323846;
    u -= floor(u);
    /* bilinear: wrap in u, clamp in v; texel centres at +0.5 */
    vec2 f = vec2(u * float(e.width), v * float(e.height)) - 0.5;
    ivec2 i0 = ivec2(floor(f));
    vec2 t = f - vec2(i0);
    vec3 a = mix(env_texel(e, i0.x, i0.y), env_texel(e, i0.x + 1, i0.y), t.x);
    vec3 b = mix(env_texel(e, i0.x, i0.y + 1), env_texel(e, i0.x + 1, i0.y + 1), t.x);
    return mix(a, b, t.y) * e.sky.w;
}

/* Irradiance on a surface of unit normal n open to the whole environment. */
vec3 env_irradiance(pc_environment e, vec3 n)
{
    vec3 r = e.irradiance[0].rgb * 0.282095;
    r += e.irradiance[1].rgb * (0.488603 * n.y);
    r += e.irradiance[2].rgb * (0.488603 * n.z);
    r += e.irradiance[3].rgb * (0.488603 * n.x);
    r += e.irradiance[4].rgb * (1.092548 * n.x * n.y);
    r += e.irradiance[5].rgb * (1.092548 * n.y * n.z);
    r += e.irradiance[6].rgb * (0.315392 * (3.0 * n.z * n.z - 1.0));
    r += e.irradiance[7].rgb * (1.092548 * n.x * n.z);
    r += e.irradiance[8].rgb * (0.546274 * (n.x * n.x - n.y * n.y));
    return max(r, vec3(0.0));
}

#endif
