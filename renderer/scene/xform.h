/* xform.h: small 3D vector and 4x4 matrix helpers.
 *
 * Matrices are column-major float[16] as in glTF: element (row r, column c) is m[c * 4 + r],
 * the translation is m[12..14]. Points are column vectors (p' = M p). Every output pointer
 * may alias an input.
 */
#ifndef RD_XFORM_H
#define RD_XFORM_H

#include <stdbool.h>

/* ---- vec3 ------------------------------------------------------------------------------ */
void rd_vec3_set(float out[3], float x, float y, float z);
void rd_vec3_add(float out[3], const float a[3], const float b[3]);
void rd_vec3_sub(float out[3], const float a[3], const float b[3]);
void rd_vec3_scale(float out[3], const float a[3], float s);
void rd_vec3_cross(float out[3], const float a[3], const float b[3]);
float rd_vec3_dot(const float a[3], const float b[3]);
float rd_vec3_length(const float a[3]);
/* Writes a / |a| and returns true; returns false (out = fallback) when |a| is zero or not
 * finite. fallback may be NULL, then out is left untouched on failure. */
bool rd_vec3_normalize(float out[3], const float a[3], const float fallback[3]);
bool rd_vec3_isfinite(const float a[3]);

/* ---- mat4 ------------------------------------------------------------------------------ */
void rd_mat4_identity(float out[16]);
/* out = a * b (b is applied first). */
void rd_mat4_mul(float out[16], const float a[16], const float b[16]);
/* T * R * S as glTF composes a node's local matrix. q = (x, y, z, w) is normalised here; a
 * zero or non-finite quaternion gives no rotation. */
void rd_mat4_from_trs(float out[16], const float t[3], const float q[4], const float s[3]);
/* Quaternion (x, y, z, w) of a rotation matrix given by its three columns (Shoemake's
 * trace-based method, robust for every rotation angle). */
void rd_mat3_cols_to_quat(const float cols[3][3], float q[4]);
/* General inverse. Returns false (out untouched) when m is singular or not finite. */
bool rd_mat4_inverse(float out[16], const float m[16]);
/* Determinant of the upper-left 3x3 (negative: the transform mirrors, flipping winding). */
float rd_mat4_det3(const float m[16]);
/* Affine point transform (w = 1; the bottom row is ignored). */
void rd_mat4_transform_point(const float m[16], const float p[3], float out[3]);
/* Direction transform by the upper 3x3 (no translation, not normalised). */
void rd_mat4_transform_dir(const float m[16], const float d[3], float out[3]);
/* Normal transform by the inverse transpose of the upper 3x3 (not normalised). For a
 * singular matrix the cofactor matrix is used (same direction up to scale where defined). */
void rd_mat4_transform_normal(const float m[16], const float n[3], float out[3]);

#endif
