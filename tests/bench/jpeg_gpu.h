/* jpeg_gpu.h: the daemon's GPU JPEG path driven frame by frame, for probecast_jpegbench and
 * test_gpu_jpeg (issue 14: GPU JPEG against the striped CPU encoder).
 *
 * The product's pass (renderer/encode/jpeg_dct.h: colour conversion, chroma averaging, DCT and
 * quantisation with libjpeg's tables) runs on an uploaded RGBA8 frame; the coefficients are
 * copied to a host-visible buffer (or the pass writes that buffer itself: jpeg_gpu.direct); the
 * product's entropy coder (server/encode/jpeg_coefs.h) codes them on the CPU, whole on one thread or in
 * stripes of MCU rows on several threads, joined with restart markers by srv_jpeg_join.
 *
 * Use: jpeg_gpu_create, jpeg_gpu_set_frame (uploads; the renderer would have it on the GPU),
 * then per frame jpeg_gpu_transform and jpeg_gpu_entropy or jpeg_gpu_entropy_striped.
 * One thread drives a jpeg_gpu; it owns its Vulkan objects and entropy threads.
 */
#ifndef JPEG_GPU_H
#define JPEG_GPU_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/accel/task_pool.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/encode/jpeg_dct.h"
#include "server/encode/jpeg_coefs.h"
#include "server/encode/jpeg_striped.h"

#define JPEG_GPU_MAX_THREADS 64

typedef struct jpeg_gpu {
    rd_vk *vk;
    rd_jpeg_dct dct;
    rd_buffer frame;      /* device local: width * height RGBA8 pixels */
    rd_buffer coefs;      /* device local: the quantised coefficients */
    rd_buffer coefs_host; /* RD_MEMORY_READBACK: their copy, read by the entropy coders */
    rd_buffer frame_host; /* RD_MEMORY_READBACK: the frame, for jpeg_gpu_time_frame_copy */
    rd_buffer sets;       /* device local: coefficient sets for jpeg_gpu_time_sets */
    rd_timer timer;
    unsigned width, height, quality;
    bool direct; /* the pass writes coefs_host itself over the bus (no coefs, no copy) */

    /* entropy coding: one libjpeg compressor per stripe (coders[0] also codes whole frames),
     * stripes run as tasks on a pool of pool_threads threads (renderer/accel/task_pool.h) */
    srv_jpeg_encoder *coders[JPEG_GPU_MAX_THREADS];
    unsigned coder_count;
    rd_task_pool *pool; /* NULL for one thread */
    unsigned pool_threads;
} jpeg_gpu;

/* Timings of jpeg_gpu_transform, from GPU timestamps (0 when the device has none) and the
 * host clock. */
typedef struct jpeg_gpu_times {
    double dct_ms;  /* the compute pass */
    double copy_ms; /* the copy of the coefficients to host-visible memory */
    double wall_ms; /* record, submit and wait, on the host */
} jpeg_gpu_times;

/* Creates the pipeline and the coder of the calling thread on vk (which must outlive g). */
rd_vk_result jpeg_gpu_create(jpeg_gpu *g, rd_vk *vk, char *err, size_t errlen);
/* Stops the threads, frees everything; idempotent. */
void jpeg_gpu_destroy(jpeg_gpu *g);

/* Uploads width x height RGBA8 pixels (tight rows, top row first) to be quantised at `quality`
 * (1-100), growing the buffers as needed. */
rd_vk_result jpeg_gpu_set_frame(jpeg_gpu *g, const uint8_t *rgba, unsigned width, unsigned height,
                                unsigned quality, char *err, size_t errlen);
/* Runs the compute pass and the copy on the frame (or the pass alone, writing host memory, when
 * g->direct), waits: the coefficients are then in g->coefs_host. times may be NULL. */
rd_vk_result jpeg_gpu_transform(jpeg_gpu *g, jpeg_gpu_times *times, char *err, size_t errlen);

/* For comparison, what the CPU encoders' input costs instead: the frame copied to host-visible
 * memory as the renderer's readback does (renderer/vk/readback.c). times->dct_ms is 0. */
rd_vk_result jpeg_gpu_time_frame_copy(jpeg_gpu *g, jpeg_gpu_times *times, char *err, size_t errlen);

/* GPU time (ms, from timestamps; 0 without them) of the frame's coefficients at n qualities
 * (qualities[0..n), n <= RD_JPEG_MAX_SETS): in one pass (fused, as the daemon quantises a frame's
 * lag variants), or in n passes of one quality each. */
rd_vk_result jpeg_gpu_time_sets(jpeg_gpu *g, const unsigned *qualities, unsigned n, bool fused,
                                double *ms, char *err, size_t errlen);

/* Entropy-codes the coefficients as one baseline JPEG (no restart markers) on this thread
 * into out. false on a libjpeg error (message in err). */
bool jpeg_gpu_entropy(jpeg_gpu *g, srv_jpeg_buf *out, char *err, size_t errlen);
/* The same in stripes: threads (1..JPEG_GPU_MAX_THREADS; the pool is kept while the count stays)
 * encode the plan's stripes (srv_jpeg_plan_make for the frame), each with a restart interval of one
 * stripe, into stripes[] (plan->stripe_count buffers), and this thread joins them into out:
 * the bytes of one encode with that restart interval. */
bool jpeg_gpu_entropy_striped(jpeg_gpu *g, unsigned threads, const srv_jpeg_plan *plan,
                              srv_jpeg_buf *stripes, srv_jpeg_buf *out, char *err, size_t errlen);

/* The coefficients of the last jpeg_gpu_transform (in g->coefs_host), for srv_jpeg_encode_coefs. */
srv_jpeg_coefs jpeg_gpu_coefs(const jpeg_gpu *g);

#endif
