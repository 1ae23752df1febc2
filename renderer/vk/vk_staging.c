/* vk_staging.c: uploads staged on any thread, recorded by the queue's thread (vk_staging.h). */
#include "renderer/vk/vk_staging.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* The next free entry of s (grown as needed). */
static rd_staging_copy *next_copy(rd_staging *s)
{
    if (s->count == s->capacity) {
        uint32_t cap = s->capacity ? s->capacity * 2 : 8;
        rd_staging_copy *c = realloc(s->copies, sizeof *c * cap);
        if (!c) abort();
        s->copies = c;
        s->capacity = cap;
    }
    rd_staging_copy *c = &s->copies[s->count];
    memset(c, 0, sizeof *c);
    return c;
}

static bool fits(const rd_buffer *dst, VkDeviceSize offset, VkDeviceSize size, char *err,
                 size_t errlen)
{
    if (dst->buffer && offset <= dst->size && size <= dst->size - offset) return true;
    rd_vk_errorf(err, errlen, "Staging: %llu bytes at %llu do not fit the buffer (%llu).",
                 (unsigned long long)size, (unsigned long long)offset,
                 (unsigned long long)dst->size);
    return false;
}

rd_vk_result rd_staging_adopt(rd_staging *s, rd_buffer *src, rd_buffer *dst, VkDeviceSize offset,
                              char *err, size_t errlen)
{
    if (!src->mapped) {
        rd_vk_errorf(err, errlen, "Staging: the source is not host visible.");
        return RD_VK_ERR_VULKAN;
    }
    if (!fits(dst, offset, src->size, err, errlen)) return RD_VK_ERR_VULKAN;
    rd_staging_copy *c = next_copy(s);
    c->src = *src;
    c->dst = dst->buffer;
    c->offset = offset;
    c->size = src->size;
    memset(src, 0, sizeof *src);
    s->count++;
    s->bytes += c->size;
    return RD_VK_OK;
}

rd_vk_result rd_staging_add(rd_vk *vk, rd_staging *s, rd_buffer *dst, VkDeviceSize offset,
                            const void *src, VkDeviceSize size, void **mapped, char *err,
                            size_t errlen)
{
    if (mapped) *mapped = NULL;
    if (size == 0) return RD_VK_OK;
    if (!fits(dst, offset, size, err, errlen)) return RD_VK_ERR_VULKAN;
    rd_staging_copy *c = next_copy(s);
    rd_vk_result r = rd_buffer_create(vk, &c->src, size, RD_MEMORY_UPLOAD, err, errlen);
    if (r != RD_VK_OK) return r;
    c->dst = dst->buffer;
    c->offset = offset;
    c->size = size;
    if (src) r = rd_buffer_upload(vk, &c->src, 0, src, size, err, errlen); /* a memcpy */
    if (r != RD_VK_OK) {
        rd_buffer_destroy(vk, &c->src);
        return r;
    }
    if (mapped) *mapped = c->src.mapped;
    s->count++;
    s->bytes += size;
    return RD_VK_OK;
}

void rd_staging_record(const rd_staging *s, rd_cmd *cmd)
{
    if (s->count == 0) return; /* no barrier either */
    for (uint32_t i = 0; i < s->count; i++) {
        const rd_staging_copy *c = &s->copies[i];
        VkBufferCopy region = {.srcOffset = 0, .dstOffset = c->offset, .size = c->size};
        vkCmdCopyBuffer(cmd->cb, c->src.buffer, c->dst, 1, &region);
    }
    rd_cmd_barrier(cmd);
}

rd_vk_result rd_staging_submit_wait(rd_vk *vk, rd_staging *s, char *err, size_t errlen)
{
    rd_vk_result r = RD_VK_OK;
    if (s->count) {
        rd_cmd cmd;
        r = rd_cmd_begin(vk, &cmd, err, errlen);
        if (r == RD_VK_OK) {
            rd_staging_record(s, &cmd);
            r = rd_cmd_submit_wait(vk, &cmd, err, errlen);
        }
    }
    rd_staging_release(vk, s);
    return r;
}

void rd_staging_release(rd_vk *vk, rd_staging *s)
{
    for (uint32_t i = 0; i < s->count; i++)
        rd_buffer_destroy(vk, &s->copies[i].src);
    free(s->copies);
    memset(s, 0, sizeof *s);
}

rd_vk_result rd_upload(rd_vk *vk, rd_staging *s, rd_buffer *dst, VkDeviceSize offset,
                       const void *src, VkDeviceSize size, char *err, size_t errlen)
{
    if (!s) return rd_buffer_upload(vk, dst, offset, src, size, err, errlen);
    return rd_staging_add(vk, s, dst, offset, src, size, NULL, err, errlen);
}
