/* gltf_animation.c: reading and checking a glTF animation sampler's keys (glTF 2.0 section
 * 3.11; see gltf_import.h). */
#include "gltf_import.h"

#include <math.h>

rd_gltf_result rd_gltf_read_keys(const char *where, const rd_gltf_accessor *in,
                                 const rd_gltf_accessor *val, uint32_t components, float *times,
                                 float *values, char *err, size_t errlen)
{
    for (size_t i = 0; i < in->count; i++) {
        float *t = &times[i];
        rd_gltf_read_floats(in, i, t);
        if (!isfinite(*t) || *t < 0.0f || (i > 0 && *t < t[-1]))
            return rd_gltf_fail(
                err, errlen, RD_GLTF_ERR_INVALID,
                "%s has input time %g at key %zu; times must be finite, >= 0 and not decrease",
                where, (double)*t, i);
    }
    for (size_t i = 0; i < val->count; i++) {
        float *v = &values[i * components];
        rd_gltf_read_floats(val, i, v);
        for (uint32_t k = 0; k < components; k++)
            if (!isfinite(v[k]))
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "%s has an output value that is NaN or infinite (%zu)", where,
                                    i);
    }
    return RD_GLTF_OK;
}
