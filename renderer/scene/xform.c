/* xform.c: vec3 and column-major mat4 helpers (see xform.h). */
#include "renderer/scene/xform.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define M(m, r, c) ((m)[(c)*4 + (r)])

/* double -> float with IEEE overflow to infinity (a plain cast of an out-of-range value is
 * undefined behaviour in C). */
static float narrow(double v)
{
    if (v > FLT_MAX) return INFINITY;
    if (v < -FLT_MAX) return -INFINITY;
    return (float)v;
}

void rd_vec3_set(float out[3], float x, float y, float z)
{
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

void rd_vec3_add(float out[3], const float a[3], const float b[3])
{
    rd_vec3_set(out, a[0] + b[0], a[1] + b[1], a[2] + b[2]);
}

void rd_vec3_sub(float out[3], const float a[3], const float b[3])
{
    rd_vec3_set(out, a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

void rd_vec3_scale(float out[3], const float a[3], float s)
{
    rd_vec3_set(out, a[0] * s, a[1] * s, a[2] * s);
}

void rd_vec3_cross(float out[3], const float a[3], const float b[3])
{
    rd_vec3_set(out, a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0]);
}

float rd_vec3_dot(const float a[3], const float b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

float rd_vec3_length(const float a[3])
{
    /* double: squares of small or large floats neither underflow nor overflow */
    double x = a[0], y = a[1], z = a[2];
    return narrow(sqrt(x * x + y * y + z * z));
}

bool rd_vec3_normalize(float out[3], const float a[3], const float fallback[3])
{
    double x = a[0], y = a[1], z = a[2];
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len)) {
        if (fallback) rd_vec3_set(out, fallback[0], fallback[1], fallback[2]);
        return false;
    }
    rd_vec3_set(out, (float)(x / len), (float)(y / len), (float)(z / len));
    return true;
}

bool rd_vec3_isfinite(const float a[3])
{
    return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]);
}

void rd_mat4_identity(float out[16])
{
    memset(out, 0, 16 * sizeof(float));
    out[0] = out[5] = out[10] = out[15] = 1.0f;
}

void rd_mat4_mul(float out[16], const float a[16], const float b[16])
{
    float r[16];
    for (int c = 0; c < 4; c++) {
        for (int row = 0; row < 4; row++) {
            float sum = 0.0f;
            for (int k = 0; k < 4; k++)
                sum += M(a, row, k) * M(b, k, c);
            M(r, row, c) = sum;
        }
    }
    memcpy(out, r, sizeof r);
}

void rd_mat4_from_trs(float out[16], const float t[3], const float q[4], const float s[3])
{
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double len = sqrt(x * x + y * y + z * z + w * w);
    if (len > 0.0 && isfinite(len)) {
        x /= len, y /= len, z /= len, w /= len;
    } else {
        x = y = z = 0.0, w = 1.0;
    }
    /* rotation matrix of a unit quaternion, columns scaled by s */
    float r[3][3] = {
        /* column 0 */
        {(float)(1 - 2 * (y * y + z * z)), (float)(2 * (x * y + z * w)),
         (float)(2 * (x * z - y * w))},
        /* column 1 */
        {(float)(2 * (x * y - z * w)), (float)(1 - 2 * (x * x + z * z)),
         (float)(2 * (y * z + x * w))},
        /* column 2 */
        {(float)(2 * (x * z + y * w)), (float)(2 * (y * z - x * w)),
         (float)(1 - 2 * (x * x + y * y))},
    };
    for (int c = 0; c < 3; c++) {
        for (int row = 0; row < 3; row++)
            M(out, row, c) = r[c][row] * s[c];
        M(out, 3, c) = 0.0f;
    }
    M(out, 0, 3) = t[0];
    M(out, 1, 3) = t[1];
    M(out, 2, 3) = t[2];
    M(out, 3, 3) = 1.0f;
}

bool rd_mat4_inverse(float out[16], const float m[16])
{
    /* cofactor expansion in double precision (MESA gluInvertMatrix layout) */
    double a[16], inv[16];
    for (int i = 0; i < 16; i++)
        a[i] = m[i];
    inv[0] = a[5] * a[10] * a[15] - a[5] * a[11] * a[14] - a[9] * a[6] * a[15] +
             a[9] * a[7] * a[14] + a[13] * a[6] * a[11] - a[13] * a[7] * a[10];
    inv[4] = -a[4] * a[10] * a[15] + a[4] * a[11] * a[14] + a[8] * a[6] * a[15] -
             a[8] * a[7] * a[14] - a[12] * a[6] * a[11] + a[12] * a[7] * a[10];
    inv[8] = a[4] * a[9] * a[15] - a[4] * a[11] * a[13] - a[8] * a[5] * a[15] +
             a[8] * a[7] * a[13] + a[12] * a[5] * a[11] - a[12] * a[7] * a[9];
    inv[12] = -a[4] * a[9] * a[14] + a[4] * a[10] * a[13] + a[8] * a[5] * a[14] -
              a[8] * a[6] * a[13] - a[12] * a[5] * a[10] + a[12] * a[6] * a[9];
    inv[1] = -a[1] * a[10] * a[15] + a[1] * a[11] * a[14] + a[9] * a[2] * a[15] -
             a[9] * a[3] * a[14] - a[13] * a[2] * a[11] + a[13] * a[3] * a[10];
    inv[5] = a[0] * a[10] * a[15] - a[0] * a[11] * a[14] - a[8] * a[2] * a[15] +
             a[8] * a[3] * a[14] + a[12] * a[2] * a[11] - a[12] * a[3] * a[10];
    inv[9] = -a[0] * a[9] * a[15] + a[0] * a[11] * a[13] + a[8] * a[1] * a[15] -
             a[8] * a[3] * a[13] - a[12] * a[1] * a[11] + a[12] * a[3] * a[9];
    inv[13] = a[0] * a[9] * a[14] - a[0] * a[10] * a[13] - a[8] * a[1] * a[14] +
              a[8] * a[2] * a[13] + a[12] * a[1] * a[10] - a[12] * a[2] * a[9];
    inv[2] = a[1] * a[6] * a[15] - a[1] * a[7] * a[14] - a[5] * a[2] * a[15] + a[5] * a[3] * a[14] +
             a[13] * a[2] * a[7] - a[13] * a[3] * a[6];
    inv[6] = -a[0] * a[6] * a[15] + a[0] * a[7] * a[14] + a[4] * a[2] * a[15] -
             a[4] * a[3] * a[14] - a[12] * a[2] * a[7] + a[12] * a[3] * a[6];
    inv[10] = a[0] * a[5] * a[15] - a[0] * a[7] * a[13] - a[4] * a[1] * a[15] +
              a[4] * a[3] * a[13] + a[12] * a[1] * a[7] - a[12] * a[3] * a[5];
    inv[14] = -a[0] * a[5] * a[14] + a[0] * a[6] * a[13] + a[4] * a[1] * a[14] -
              a[4] * a[2] * a[13] - a[12] * a[1] * a[6] + a[12] * a[2] * a[5];
    inv[3] = -a[1] * a[6] * a[11] + a[1] * a[7] * a[10] + a[5] * a[2] * a[11] -
             a[5] * a[3] * a[10] - a[9] * a[2] * a[7] + a[9] * a[3] * a[6];
    inv[7] = a[0] * a[6] * a[11] - a[0] * a[7] * a[10] - a[4] * a[2] * a[11] + a[4] * a[3] * a[10] +
             a[8] * a[2] * a[7] - a[8] * a[3] * a[6];
    inv[11] = -a[0] * a[5] * a[11] + a[0] * a[7] * a[9] + a[4] * a[1] * a[11] - a[4] * a[3] * a[9] -
              a[8] * a[1] * a[7] + a[8] * a[3] * a[5];
    inv[15] = a[0] * a[5] * a[10] - a[0] * a[6] * a[9] - a[4] * a[1] * a[10] + a[4] * a[2] * a[9] +
              a[8] * a[1] * a[6] - a[8] * a[2] * a[5];
    double det = a[0] * inv[0] + a[1] * inv[4] + a[2] * inv[8] + a[3] * inv[12];
    if (det == 0.0 || !isfinite(det)) return false;
    float r[16];
    for (int i = 0; i < 16; i++) {
        double v = inv[i] / det;
        if (!isfinite(v) || fabs(v) > FLT_MAX) return false;
        r[i] = (float)v;
    }
    memcpy(out, r, sizeof r);
    return true;
}

float rd_mat4_det3(const float m[16])
{
    double a = M(m, 0, 0), b = M(m, 0, 1), c = M(m, 0, 2);
    double d = M(m, 1, 0), e = M(m, 1, 1), f = M(m, 1, 2);
    double g = M(m, 2, 0), h = M(m, 2, 1), i = M(m, 2, 2);
    return narrow(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g));
}

void rd_mat4_transform_point(const float m[16], const float p[3], float out[3])
{
    float x = p[0], y = p[1], z = p[2];
    rd_vec3_set(out, M(m, 0, 0) * x + M(m, 0, 1) * y + M(m, 0, 2) * z + M(m, 0, 3),
                M(m, 1, 0) * x + M(m, 1, 1) * y + M(m, 1, 2) * z + M(m, 1, 3),
                M(m, 2, 0) * x + M(m, 2, 1) * y + M(m, 2, 2) * z + M(m, 2, 3));
}

void rd_mat4_transform_dir(const float m[16], const float d[3], float out[3])
{
    float x = d[0], y = d[1], z = d[2];
    rd_vec3_set(out, M(m, 0, 0) * x + M(m, 0, 1) * y + M(m, 0, 2) * z,
                M(m, 1, 0) * x + M(m, 1, 1) * y + M(m, 1, 2) * z,
                M(m, 2, 0) * x + M(m, 2, 1) * y + M(m, 2, 2) * z);
}

void rd_mat4_transform_normal(const float m[16], const float n[3], float out[3])
{
    /* inverse transpose = cofactor matrix / det; cof(r, c) multiplies n[c] */
    double a = M(m, 0, 0), b = M(m, 0, 1), c = M(m, 0, 2);
    double d = M(m, 1, 0), e = M(m, 1, 1), f = M(m, 1, 2);
    double g = M(m, 2, 0), h = M(m, 2, 1), i = M(m, 2, 2);
    double cof[3][3] = {
        {e * i - f * h, -(d * i - f * g), d * h - e * g},
        {-(b * i - c * h), a * i - c * g, -(a * h - b * g)},
        {b * f - c * e, -(a * f - c * d), a * e - b * d},
    };
    double det = a * cof[0][0] + b * cof[0][1] + c * cof[0][2];
    double s = (det != 0.0 && isfinite(det)) ? 1.0 / det : 1.0;
    double x = n[0], y = n[1], z = n[2];
    rd_vec3_set(out, narrow((cof[0][0] * x + cof[0][1] * y + cof[0][2] * z) * s),
                narrow((cof[1][0] * x + cof[1][1] * y + cof[1][2] * z) * s),
                narrow((cof[2][0] * x + cof[2][1] * y + cof[2][2] * z) * s));
}

void rd_mat3_cols_to_quat(const float cols[3][3], float q[4])
{
    float m00 = cols[0][0], m01 = cols[1][0], m02 = cols[2][0];
    float m10 = cols[0][1], m11 = cols[1][1], m12 = cols[2][1];
    float m20 = cols[0][2], m21 = cols[1][2], m22 = cols[2][2];
    float tr = m00 + m11 + m22;
    if (tr > 0) {
        float s = sqrtf(tr + 1.0f) * 2;
        q[3] = 0.25f * s, q[0] = (m21 - m12) / s, q[1] = (m02 - m20) / s, q[2] = (m10 - m01) / s;
    } else if (m00 > m11 && m00 > m22) {
        float s = sqrtf(1.0f + m00 - m11 - m22) * 2;
        q[3] = (m21 - m12) / s, q[0] = 0.25f * s, q[1] = (m01 + m10) / s, q[2] = (m02 + m20) / s;
    } else if (m11 > m22) {
        float s = sqrtf(1.0f + m11 - m00 - m22) * 2;
        q[3] = (m02 - m20) / s, q[0] = (m01 + m10) / s, q[1] = 0.25f * s, q[2] = (m12 + m21) / s;
    } else {
        float s = sqrtf(1.0f + m22 - m00 - m11) * 2;
        q[3] = (m10 - m01) / s, q[0] = (m02 + m20) / s, q[1] = (m12 + m21) / s, q[2] = 0.25f * s;
    }
}
