/* gltf_accessor.c: reading the elements of a validated glTF accessor (see gltf_import.h). */
#include "gltf_import.h"

#include <string.h>

size_t rd_gltf_component_size(int ctype)
{
    switch (ctype) {
    case RD_GLTF_BYTE:
    case RD_GLTF_UNSIGNED_BYTE:
        return 1;
    case RD_GLTF_SHORT:
    case RD_GLTF_UNSIGNED_SHORT:
        return 2;
    case RD_GLTF_UNSIGNED_INT:
    case RD_GLTF_FLOAT:
        return 4;
    default:
        return 0;
    }
}

bool rd_gltf_read_sparse_indices(const unsigned char *p, int ctype, size_t n, size_t count,
                                 uint32_t *out)
{
    size_t isz = rd_gltf_component_size(ctype);
    for (size_t i = 0; i < n; i++) {
        uint32_t v = 0;
        if (isz == 1) {
            v = p[i];
        } else if (isz == 2) {
            uint16_t s;
            memcpy(&s, p + i * 2, 2);
            v = s;
        } else {
            memcpy(&v, p + i * 4, 4);
        }
        if (v >= count || (i > 0 && v <= out[i - 1])) return false;
        out[i] = v;
    }
    return true;
}

/* Bytes of element i (null: zeros). */
static const unsigned char *element(const rd_gltf_accessor *a, size_t i)
{
    if (a->sparse_count) { /* lower bound in the increasing sparse indices */
        size_t lo = 0, hi = a->sparse_count;
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (a->sparse_index[mid] < (uint32_t)i)
                lo = mid + 1;
            else
                hi = mid;
        }
        if (lo < a->sparse_count && a->sparse_index[lo] == i)
            return a->sparse_values + lo * a->elem;
    }
    return a->data ? a->data + i * a->stride : NULL;
}

static float max1(float v)
{
    return v < -1.0f ? -1.0f : v;
}

void rd_gltf_read_floats(const rd_gltf_accessor *a, size_t i, float *out)
{
    const unsigned char *p = element(a, i);
    for (int c = 0; c < a->ncomp; c++) {
        if (!p) {
            out[c] = 0.0f;
        } else if (a->ctype == RD_GLTF_FLOAT) {
            memcpy(&out[c], p + c * 4, 4);
        } else if (a->ctype == RD_GLTF_UNSIGNED_BYTE) {
            out[c] = p[c] / 255.0f;
        } else if (a->ctype == RD_GLTF_BYTE) {
            out[c] = max1((int8_t)p[c] / 127.0f);
        } else if (a->ctype == RD_GLTF_SHORT) {
            int16_t s;
            memcpy(&s, p + c * 2, 2);
            out[c] = max1(s / 32767.0f);
        } else { /* normalized unsigned short */
            uint16_t s;
            memcpy(&s, p + c * 2, 2);
            out[c] = s / 65535.0f;
        }
    }
}

uint32_t rd_gltf_read_index(const rd_gltf_accessor *a, size_t i)
{
    const unsigned char *p = element(a, i);
    if (!p) return 0;
    if (a->ctype == RD_GLTF_UNSIGNED_BYTE) return p[0];
    if (a->ctype == RD_GLTF_UNSIGNED_SHORT) {
        uint16_t s;
        memcpy(&s, p, 2);
        return s;
    }
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}
