/* vk_staging.h: uploads prepared on any thread, copied later by the thread that owns the queue.
 *
 * A large upload (a new scene's BVHs and textures, an environment image) used to be converted
 * and copied on the render thread, through staging buffers and one queue wait per chunk: every
 * view's frame waited 100 ms and more (issue 30). Staging splits it in two:
 *   - any thread: rd_staging_add fills host-visible buffers with the contents (buffer creation,
 *     allocation and mapping are free-threaded in Vulkan; nothing is submitted);
 *   - the queue's thread: rd_staging_record puts the copies into a command buffer (or
 *     rd_staging_submit_wait runs them alone), then rd_staging_release frees the staging memory
 *     once that command buffer has completed.
 * Destination buffers are device-local buffers created by the caller (on any thread too).
 */
#ifndef RD_VK_STAGING_H
#define RD_VK_STAGING_H

#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

typedef struct rd_staging_copy {
    rd_buffer src; /* host visible, owned */
    VkBuffer dst;  /* not owned */
    VkDeviceSize offset, size;
} rd_staging_copy;

typedef struct rd_staging {
    rd_staging_copy *copies;
    uint32_t count, capacity;
    VkDeviceSize bytes; /* staged so far */
} rd_staging;

/* Stages size bytes for dst at offset: from src when given; with src NULL the staging memory is
 * returned in *mapped for the caller to fill (write only: it may be write-combined). size 0
 * stages nothing (*mapped NULL). */
rd_vk_result rd_staging_add(rd_vk *vk, rd_staging *s, rd_buffer *dst, VkDeviceSize offset,
                            const void *src, VkDeviceSize size, void **mapped, char *err,
                            size_t errlen);
/* Stages the whole of src, a host-visible buffer the caller filled (taken: left zeroed), for dst
 * at offset. */
rd_vk_result rd_staging_adopt(rd_staging *s, rd_buffer *src, rd_buffer *dst, VkDeviceSize offset,
                              char *err, size_t errlen);
/* Records every staged copy into cmd, then a barrier that makes them visible to later compute
 * and transfer work. */
void rd_staging_record(const rd_staging *s, rd_cmd *cmd);
/* Records the copies alone, submits, waits and releases: for callers off the hot path. */
rd_vk_result rd_staging_submit_wait(rd_vk *vk, rd_staging *s, char *err, size_t errlen);
/* Frees the staging memory (the copies must have completed, or never be recorded). Idempotent. */
void rd_staging_release(rd_vk *vk, rd_staging *s);

/* Writes size bytes of src into dst at offset: staged into s when s is given (copied when s is
 * recorded), else at once (rd_buffer_upload, blocking). */
rd_vk_result rd_upload(rd_vk *vk, rd_staging *s, rd_buffer *dst, VkDeviceSize offset,
                       const void *src, VkDeviceSize size, char *err, size_t errlen);

#endif
