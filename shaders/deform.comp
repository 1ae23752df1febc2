// deform.comp: one deforming mesh posed on the GPU, one invocation per vertex: morph targets
// first, then the skin (glTF 2.0 sections 3.7.2.2 and 3.7.3.3), the same math as
// renderer/scene/deform.c (rd_mesh_deform_apply), which is the reference the test holds it to.
// Push constants: pc_deform_push (flat per-vertex arrays, the pose, the outputs).
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require

#include "gpu_types.h"

layout(local_size_x = PC_WG_1D) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Floats
{
    float v[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Uints
{
    uint v[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer FloatsOut
{
    float v[];
};

layout(push_constant) uniform Push
{
    pc_deform_push pc;
};

vec3 load3(uint64_t a, uint i)
{
    Floats f = Floats(a);
    return vec3(f.v[3 * i], f.v[3 * i + 1], f.v[3 * i + 2]);
}

void store3(uint64_t a, uint i, vec3 x)
{
    FloatsOut f = FloatsOut(a);
    f.v[3 * i] = x.x;
    f.v[3 * i + 1] = x.y;
    f.v[3 * i + 2] = x.z;
}

bool finite3(vec3 x)
{
    return !any(isnan(x)) && !any(isinf(x));
}

// rd_mat4_transform_normal: the cofactor matrix over the determinant (1 when it is 0).
vec3 transform_normal(mat4 m, vec3 n)
{
    mat3 a = transpose(mat3(m)); // a[r]: row r, so that c_r is row r of the cofactor matrix
    vec3 c0 = cross(a[1], a[2]), c1 = cross(a[2], a[0]), c2 = cross(a[0], a[1]);
    float det = dot(a[0], c0);
    float s = (det != 0.0 && !isinf(det) && !isnan(det)) ? 1.0 / det : 1.0;
    return vec3(dot(c0, n), dot(c1, n), dot(c2, n)) * s;
}

void main()
{
    uint v = gl_GlobalInvocationID.x;
    uint nv = pc.counts.x, inf = pc.counts.y, nt = pc.counts.z, nj = pc.counts.w;
    if (v >= nv) return;
    vec3 rp = load3(pc.rest_positions, v), rn = load3(pc.rest_normals, v);
    vec4 rt = vec4(0.0);
    bool tangents = pc.rest_tangents != 0 && pc.out_tangents != 0;
    if (tangents) {
        Floats f = Floats(pc.rest_tangents);
        rt = vec4(f.v[4 * v], f.v[4 * v + 1], f.v[4 * v + 2], f.v[4 * v + 3]);
    }
    vec3 p = rp, n = rn, t = rt.xyz;
    Floats w = Floats(pc.morph_weights);
    for (uint ti = 0; ti < nt; ti++) {
        float wt = w.v[ti];
        if (wt == 0.0) continue;
        uint at = ti * nv + v;
        p += wt * load3(pc.target_positions, at);
        if (pc.target_normals != 0) n += wt * load3(pc.target_normals, at);
        if (pc.target_tangents != 0) t += wt * load3(pc.target_tangents, at);
    }
    if (inf > 0 && pc.joint_mats != 0) {
        Uints js = Uints(pc.joints);
        Floats ws = Floats(pc.weights);
        Floats jm = Floats(pc.joint_mats);
        mat4 m = mat4(0.0);
        bool skinned = false;
        for (uint k = 0; k < inf; k++) {
            float wk = ws.v[v * inf + k];
            uint j = js.v[v * inf + k];
            if (!(wk != 0.0) || j >= nj) continue;
            for (int c = 0; c < 4; c++)
                m[c] += wk * vec4(jm.v[16 * j + 4 * c], jm.v[16 * j + 4 * c + 1],
                                  jm.v[16 * j + 4 * c + 2], jm.v[16 * j + 4 * c + 3]);
            skinned = true;
        }
        if (skinned) {
            m[3][3] = 1.0;
            p = (m * vec4(p, 1.0)).xyz;
            n = transform_normal(m, n);
            t = mat3(m) * t;
        }
    }
    store3(pc.out_positions, v, finite3(p) ? p : rp);
    float ln = length(n);
    store3(pc.out_normals, v, (ln > 0.0 && finite3(n / ln)) ? n / ln : rn);
    if (tangents) {
        FloatsOut o = FloatsOut(pc.out_tangents);
        float lt = length(t);
        vec4 r = (lt > 0.0 && finite3(t / lt)) ? vec4(t / lt, rt.w) : rt;
        o.v[4 * v] = r.x;
        o.v[4 * v + 1] = r.y;
        o.v[4 * v + 2] = r.z;
        o.v[4 * v + 3] = r.w;
    }
}
