/* readback.h: a ring of host-visible buffers that frames are copied into without waiting.
 *
 * After a frame is rendered, srv_readback_submit records a copy of the renderer's RGBA8 buffer
 * into a free slot and submits it with its own fence, then returns at once; the render thread
 * goes on with the next frame while the copy runs. srv_readback_poll hands completed slots to
 * a callback in submission order (on the render thread; the callback copies the pixels out).
 * A barrier at the end of each copy orders it before any later write to the source buffer.
 * Render thread only: this is Vulkan.
 *
 * Today rd_renderer_render waits for its own frame, so the ring overlaps a copy with command
 * processing and encoding, and the render loop collects a pending copy (which the GPU runs
 * before anything else) just before it starts the next blocking frame. With an asynchronous
 * render submission in the renderer, copies would overlap whole frames without change here.
 */
#ifndef SRV_READBACK_H
#define SRV_READBACK_H

#include "encoder_pool.h"
#include "renderer/vk_buffer.h"
#include "renderer/vk_compute.h"

#define SRV_READBACK_SLOTS 3

typedef struct srv_readback_slot {
    rd_buffer buffer; /* RD_MEMORY_READBACK */
    rd_cmd cmd;       /* command buffer and fence while busy */
    bool busy;
    uint64_t seq; /* submission order */
    unsigned width, height;
    srv_frame_info info;
} srv_readback_slot;

typedef struct srv_readback {
    rd_vk *vk;
    srv_readback_slot slots[SRV_READBACK_SLOTS];
    uint64_t next_seq;
} srv_readback;

void srv_readback_init(srv_readback *rb, rd_vk *vk);
/* Waits for copies in flight and frees the buffers (idempotent). */
void srv_readback_dispose(srv_readback *rb);
bool srv_readback_has_free(const srv_readback *rb);
unsigned srv_readback_busy(const srv_readback *rb);
/* Copies width * height * 4 bytes of src into a free slot (there must be one). */
rd_vk_result srv_readback_submit(srv_readback *rb, const rd_buffer *src, unsigned width,
                                 unsigned height, const srv_frame_info *info, char *err,
                                 size_t errlen);

typedef void (*srv_readback_fn)(void *user, const srv_frame_info *info, unsigned width,
                                unsigned height, const uint8_t *rgba);
/* Delivers every completed copy, oldest first, stopping at the first one still running; with
 * timeout_ns > 0 first waits up to that long for the oldest. */
rd_vk_result srv_readback_poll(srv_readback *rb, uint64_t timeout_ns, srv_readback_fn fn,
                               void *user, char *err, size_t errlen);

#endif
