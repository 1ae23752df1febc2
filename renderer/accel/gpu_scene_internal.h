/* gpu_scene_internal.h: small helpers shared by the GPU scene's two files (gpu_scene.c, the GPU
 * half; gpu_scene_prep.c, the CPU half). Not part of the renderer's interface. */
#ifndef RD_GPU_SCENE_INTERNAL_H
#define RD_GPU_SCENE_INTERNAL_H

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "shaders/gpu_types.h"

static inline double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static inline void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size ? size : 1);
    if (!p) {
        fprintf(stderr, "probecast: out of memory\n");
        abort();
    }
    return p;
}

static inline pc_vec4 v4(const float *p, float w)
{
    return (pc_vec4){p[0], p[1], p[2], w};
}

static inline float clamp01(float x)
{
    return x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f; /* NaN -> 0 */
}

#endif
