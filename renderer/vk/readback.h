/* readback.h: a ring of host-visible buffers that frames are copied into without waiting.
 *
 * After a frame is rendered, rd_readback_submit records a copy of a view's output buffer (its
 * RGBA8 pixels, or its JPEG coefficients: renderer/encode/jpeg_dct.h) into a free slot and submits it with
 * its own fence, then returns at once; the render thread goes on with the next frame while the copy
 * runs. rd_readback_poll hands completed slots to a callback in submission order (on the render
 * thread). The callback either copies the pixels out or keeps the slot (a lease): its memory then
 * stays valid, unused by later frames, until rd_readback_release, which any thread may call
 * (encoders read the pixels where the GPU put them; at 1920x1080 the copy cost the render thread
 * about 1 ms a frame). A barrier at the end of each copy orders it before any later write to the
 * source buffer. Render thread only (this is Vulkan), except rd_readback_release.
 *
 * One ring can carry frames of different sizes (several views): a slot's buffer grows when a
 * frame does not fit and is kept otherwise. Each frame carries an opaque caller record (info,
 * copied into the slot) that comes back with its pixels.
 */
#ifndef RD_READBACK_H
#define RD_READBACK_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

/* frames in flight (the GPU works while the CPU records the next) plus leased slots; a slot's
 * buffer is allocated when first used */
#define RD_READBACK_SLOTS 32
#define RD_READBACK_INFO_MAX 128 /* bytes of caller record per frame */

typedef struct rd_readback_slot {
    rd_buffer buffer; /* RD_MEMORY_READBACK; at least bytes */
    rd_cmd cmd;       /* command buffer and fence while busy */
    bool busy;
    atomic_bool leased; /* delivered and kept by the callback until rd_readback_release */
    uint64_t seq;       /* submission order */
    unsigned width, height;
    size_t bytes;
    size_t info_size;
    _Alignas(16) unsigned char info[RD_READBACK_INFO_MAX];
} rd_readback_slot;

typedef struct rd_readback {
    rd_vk *vk;
    rd_readback_slot slots[RD_READBACK_SLOTS];
    rd_readback_slot *open; /* begun by rd_readback_begin, not yet finished */
    uint64_t next_seq;
} rd_readback;

void rd_readback_init(rd_readback *rb, rd_vk *vk);
/* Waits for copies in flight and frees the buffers (idempotent). */
void rd_readback_dispose(rd_readback *rb);
bool rd_readback_has_free(const rd_readback *rb);
/* Slots neither in flight nor leased. */
unsigned rd_readback_free_count(const rd_readback *rb);
unsigned rd_readback_busy(const rd_readback *rb);
/* Ends the lease of slot (any thread). */
void rd_readback_release(rd_readback *rb, unsigned slot);
/* Copies the first `bytes` bytes of src (a width x height image in the caller's format) into a
 * free slot (there must be one), with a copy of info_size <= RD_READBACK_INFO_MAX bytes of info
 * (info may be NULL when info_size is 0). */
rd_vk_result rd_readback_submit(rd_readback *rb, const rd_buffer *src, size_t bytes, unsigned width,
                                unsigned height, const void *info, size_t info_size, char *err,
                                size_t errlen);

/* A frame and its copy in one submission, without waiting: rd_readback_begin takes a free slot
 * and begins its command buffer (*cmd) for the caller to record the frame into; rd_readback_finish
 * appends the copy of src and submits with the slot's fence; rd_readback_abort drops a begun slot
 * (an error while recording). rd_readback_submit is begin + finish around nothing. */
rd_vk_result rd_readback_begin(rd_readback *rb, rd_cmd **cmd, char *err, size_t errlen);
rd_vk_result rd_readback_finish(rd_readback *rb, const rd_buffer *src, size_t bytes, unsigned width,
                                unsigned height, const void *info, size_t info_size, char *err,
                                size_t errlen);
void rd_readback_abort(rd_readback *rb);
/* rd_readback_finish of several sources, copied end to end into the slot in order (a frame's
 * JPEG coefficients, then its I420 planes). */
typedef struct rd_readback_part {
    const rd_buffer *src;
    size_t bytes; /* the first bytes of src */
} rd_readback_part;
rd_vk_result rd_readback_finish_parts(rd_readback *rb, const rd_readback_part *parts, unsigned n,
                                      unsigned width, unsigned height, const void *info,
                                      size_t info_size, char *err, size_t errlen);

/* info: the slot's copy of the submitted record (aligned to 16 bytes, valid during the call);
 * data: the bytes copied, valid during the call; slot: the slot's index. Return true to keep it
 * leased (data then stays valid until rd_readback_release(rb, slot)), false when done with it. */
typedef bool (*rd_readback_fn)(void *user, const void *info, unsigned width, unsigned height,
                               const uint8_t *data, size_t bytes, unsigned slot);
/* Delivers every completed copy, oldest first, stopping at the first one still running; with
 * timeout_ns > 0 first waits up to that long for the oldest. */
rd_vk_result rd_readback_poll(rd_readback *rb, uint64_t timeout_ns, rd_readback_fn fn, void *user,
                              char *err, size_t errlen);

#endif
