/* gltf_accessor.c: validating a document's accessor against its buffer views (gltf_document.h)
 * and reading the elements of a validated one (gltf_import.h). */
#include "renderer/gltf/gltf_document.h"

#include <stdio.h>
#include <stdlib.h>
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

void rd_gltf_read_uints(const rd_gltf_accessor *a, size_t i, uint32_t *out)
{
    const unsigned char *p = element(a, i);
    size_t size = rd_gltf_component_size(a->ctype);
    for (int c = 0; c < a->ncomp; c++) {
        uint32_t v = 0;
        if (p && size == 1) {
            v = p[c];
        } else if (p && size == 2) {
            uint16_t s;
            memcpy(&s, p + c * 2, 2);
            v = s;
        } else if (p) {
            memcpy(&v, p + c * 4, 4);
        }
        out[c] = v;
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

/* ---- resolving a document's accessor ------------------------------------------------------ */

static const char *type_name(int type)
{
    switch (type) {
    case RD_GLTF_TYPE_SCALAR:
        return "SCALAR";
    case RD_GLTF_TYPE_VEC2:
        return "VEC2";
    case RD_GLTF_TYPE_VEC3:
        return "VEC3";
    case RD_GLTF_TYPE_VEC4:
        return "VEC4";
    case RD_GLTF_TYPE_MAT2:
        return "MAT2";
    case RD_GLTF_TYPE_MAT3:
        return "MAT3";
    case RD_GLTF_TYPE_MAT4:
        return "MAT4";
    default:
        return "unknown";
    }
}

/* *out = start of `bytes` bytes at `offset` inside buffer view `view`. */
static rd_gltf_result view_range(const rd_gltf_document *d, int view, uint64_t offset,
                                 uint64_t bytes, int accessor, const char *what,
                                 const unsigned char **out, char *err, size_t errlen)
{
    if (view < 0 || (size_t)view >= d->view_count)
        return rd_gltf_fail(
            err, errlen, RD_GLTF_ERR_INVALID,
            "accessor %d (%s) refers to buffer view %d, but there are only %zu buffer views",
            accessor, what, view, d->view_count);
    const rd_gltf_doc_buffer_view *bv = &d->views[view];
    if (bv->buffer < 0 || (size_t)bv->buffer >= d->buffer_count)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "buffer view %d refers to buffer %d, which does not exist", view,
                            bv->buffer);
    const rd_gltf_str *data = &d->buffers[bv->buffer];
    if (bv->byte_offset > data->len || bv->byte_length > data->len - bv->byte_offset)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "buffer view %d does not fit in buffer %d", view, bv->buffer);
    if (offset > bv->byte_length || bytes > bv->byte_length - offset)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) reads past the end of buffer view %d", accessor, what,
                            view);
    *out = (const unsigned char *)data->s + bv->byte_offset + offset;
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_resolve_accessor(const rd_gltf_document *d, int index, const char *what,
                                        int type, const int *ctypes, size_t nctypes,
                                        rd_gltf_accessor *c, char *err, size_t errlen)
{
    bool integers = (type & RD_GLTF_INTEGERS) != 0;
    type &= ~RD_GLTF_INTEGERS;
    memset(c, 0, sizeof *c);
    c->index = -1;
    if (index < 0 || (size_t)index >= d->accessor_count)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "%s refers to accessor %d, but there are only %zu accessors", what,
                            index, d->accessor_count);
    const rd_gltf_doc_accessor *a = &d->accessors[index];
    c->index = index;
    if (a->type != type)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) has type %s, expected %s", index, what,
                            type_name(a->type), type_name(type));
    bool allowed = false;
    for (size_t i = 0; i < nctypes; i++)
        allowed = allowed || ctypes[i] == a->component_type;
    if (!allowed)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) has component type %d, which is not allowed here",
                            index, what, a->component_type);
    if (a->component_type != RD_GLTF_FLOAT && type != RD_GLTF_TYPE_SCALAR && !a->normalized &&
        !integers)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) holds integers but is not normalized", index, what);
    if (a->count == 0)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID, "accessor %d (%s) has count 0", index,
                            what);
    c->ctype = a->component_type;
    c->ncomp = type == RD_GLTF_TYPE_SCALAR ? 1
               : type == RD_GLTF_TYPE_VEC2 ? 2
               : type == RD_GLTF_TYPE_VEC3 ? 3
               : type == RD_GLTF_TYPE_MAT4 ? 16 /* float only: no column padding */
                                           : 4;
    c->elem = rd_gltf_component_size(a->component_type) * (size_t)c->ncomp;
    c->count = a->count;
    c->normalized = a->normalized;
    if (a->buffer_view < -1)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID, "accessor %d (%s) has buffer view %d",
                            index, what, a->buffer_view);
    rd_gltf_result r;
    if (a->buffer_view >= 0) {
        const rd_gltf_doc_buffer_view *bv =
            (size_t)a->buffer_view < d->view_count ? &d->views[a->buffer_view] : NULL;
        c->stride = bv && bv->byte_stride ? bv->byte_stride : c->elem;
        if (c->stride < c->elem)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "buffer view %d has byteStride %zu, smaller than the %zu-byte "
                                "elements of accessor %d",
                                a->buffer_view, c->stride, c->elem, index);
        uint64_t span;
        if (__builtin_mul_overflow((uint64_t)c->stride, (uint64_t)(c->count - 1), &span) ||
            __builtin_add_overflow(span, (uint64_t)c->elem, &span))
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "accessor %d (%s) reads past the end of buffer view %d", index,
                                what, a->buffer_view);
        r = view_range(d, a->buffer_view, a->byte_offset, span, index, what, &c->data, err, errlen);
        if (r != RD_GLTF_OK) return r;
    }
    if (!a->sparse) return RD_GLTF_OK;
    size_t n = a->sparse_count > 0 ? (size_t)a->sparse_count : 0;
    if (n == 0 || n > c->count)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) has an invalid sparse count %d", index, what,
                            a->sparse_count);
    int ict = a->sparse_index_type;
    if (ict != RD_GLTF_UNSIGNED_BYTE && ict != RD_GLTF_UNSIGNED_SHORT &&
        ict != RD_GLTF_UNSIGNED_INT)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) has sparse indices of component type %d", index, what,
                            ict);
    if (a->sparse_index_offset < 0 || a->sparse_value_offset < 0)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "accessor %d (%s) has a negative sparse byteOffset", index, what);
    size_t isz = rd_gltf_component_size(ict);
    const unsigned char *ip;
    r = view_range(d, a->sparse_index_view, (uint64_t)a->sparse_index_offset, (uint64_t)n * isz,
                   index, what, &ip, err, errlen);
    if (r == RD_GLTF_OK)
        r = view_range(d, a->sparse_value_view, (uint64_t)a->sparse_value_offset,
                       (uint64_t)n * c->elem, index, what, &c->sparse_values, err, errlen);
    if (r != RD_GLTF_OK) return r;
    uint32_t *indices = malloc(n * sizeof *indices);
    if (!indices) {
        fprintf(stderr, "probecast: out of memory (%zu sparse indices)\n", n);
        abort();
    }
    if (!rd_gltf_read_sparse_indices(ip, ict, n, c->count, indices)) {
        free(indices);
        return rd_gltf_fail(
            err, errlen, RD_GLTF_ERR_INVALID,
            "the sparse indices of accessor %d (%s) are out of range or not increasing", index,
            what);
    }
    c->sparse_index = indices;
    c->sparse_count = n;
    return RD_GLTF_OK;
}

void rd_gltf_accessor_dispose(rd_gltf_accessor *a)
{
    free((void *)a->sparse_index);
    a->sparse_index = NULL;
    a->sparse_count = 0;
}
