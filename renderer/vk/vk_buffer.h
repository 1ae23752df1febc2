/* vk_buffer.h: GPU buffers reached by device address, plus blocking upload/readback.
 *
 * Every buffer is created with SHADER_DEVICE_ADDRESS usage; device-local buffers are filled
 * through a staging buffer in chunks (so arbitrarily large uploads work). Host-visible
 * buffers are persistently mapped (mapped != NULL).
 */
#ifndef RD_VK_BUFFER_H
#define RD_VK_BUFFER_H

#include "renderer/vk/vk_context.h"

typedef enum rd_memory {
    RD_MEMORY_DEVICE = 0, /* device local */
    RD_MEMORY_UPLOAD,     /* host visible, coherent, written by the CPU */
    RD_MEMORY_READBACK,   /* host visible, cached if possible, read by the CPU */
} rd_memory;

typedef struct rd_buffer {
    VkBuffer buffer;
    VkDeviceMemory memory;
    VkDeviceSize size;
    VkDeviceAddress address;
    void *mapped;                       /* UPLOAD and READBACK buffers only */
    VkDeviceSize alloc_size;            /* size of the memory allocation (>= size) */
    VkMemoryPropertyFlags memory_flags; /* of the chosen memory type */
    rd_memory where;
} rd_buffer;

/* Creates a buffer of size bytes (size 0 is rounded up to 16 so that it has an address).
 * RD_MEMORY_DEVICE buffers are never mapped, even where device memory is host visible
 * (lavapipe, ReBAR), so the staging path is the one exercised everywhere. */
rd_vk_result rd_buffer_create(rd_vk *vk, rd_buffer *b, VkDeviceSize size, rd_memory where,
                              char *err, size_t errlen);
/* The same with usage flags beyond the renderer's (storage, transfer, device address, indirect),
 * for tools: tests/bench/rt_driver.c adds acceleration-structure and shader-binding-table
 * usage. rd_buffer_create passes 0. */
rd_vk_result rd_buffer_create_usage(rd_vk *vk, rd_buffer *b, VkDeviceSize size, rd_memory where,
                                    VkBufferUsageFlags extra_usage, char *err, size_t errlen);
void rd_buffer_destroy(rd_vk *vk, rd_buffer *b); /* idempotent */
/* Blocking copies between host memory and any buffer. Mapped buffers are copied with memcpy
 * (flushing or invalidating non-coherent memory); others go through a staging buffer in chunks
 * of at most 64 MiB. offset + size must lie within b->size; size 0 does nothing. Transfers
 * end with a barrier that makes their writes visible to later compute work. Before
 * downloading a buffer written by a shader, end that work with rd_cmd_barrier (its
 * destination includes transfers and the host). */
rd_vk_result rd_buffer_upload(rd_vk *vk, rd_buffer *dst, VkDeviceSize offset, const void *src,
                              VkDeviceSize size, char *err, size_t errlen);
rd_vk_result rd_buffer_download(rd_vk *vk, const rd_buffer *src, VkDeviceSize offset, void *dst,
                                VkDeviceSize size, char *err, size_t errlen);
/* Blocking fill of the whole buffer with a 32-bit word. */
rd_vk_result rd_buffer_fill(rd_vk *vk, rd_buffer *b, uint32_t word, char *err, size_t errlen);

#endif
