/* readback.c: asynchronous frame readback through a ring of fenced copies. */
#include "renderer/vk/readback.h"

#include <string.h>

void rd_readback_init(rd_readback *rb, rd_vk *vk)
{
    memset(rb, 0, sizeof *rb);
    rb->vk = vk;
}

static void slot_release_cmd(rd_vk *vk, rd_readback_slot *s)
{
    rd_cmd_release(vk, &s->cmd);
    s->busy = false;
}

void rd_readback_dispose(rd_readback *rb)
{
    if (!rb->vk) return;
    rd_readback_abort(rb);
    for (int i = 0; i < RD_READBACK_SLOTS; i++) {
        rd_readback_slot *s = &rb->slots[i];
        if (s->busy && s->cmd.fence && !rb->vk->device_lost)
            vkWaitForFences(rb->vk->device, 1, &s->cmd.fence, VK_TRUE, UINT64_MAX);
        slot_release_cmd(rb->vk, s);
        rd_buffer_destroy(rb->vk, &s->buffer);
    }
    rb->vk = NULL;
}

static bool slot_free(const rd_readback_slot *s)
{
    return !s->busy && !atomic_load_explicit(&s->leased, memory_order_acquire);
}

unsigned rd_readback_free_count(const rd_readback *rb)
{
    unsigned n = 0;
    for (int i = 0; i < RD_READBACK_SLOTS; i++)
        n += slot_free(&rb->slots[i]);
    return n;
}

bool rd_readback_has_free(const rd_readback *rb)
{
    return rd_readback_free_count(rb) > 0;
}

void rd_readback_release(rd_readback *rb, unsigned slot)
{
    if (slot < RD_READBACK_SLOTS)
        atomic_store_explicit(&rb->slots[slot].leased, false, memory_order_release);
}

unsigned rd_readback_busy(const rd_readback *rb)
{
    unsigned n = 0;
    for (int i = 0; i < RD_READBACK_SLOTS; i++)
        n += rb->slots[i].busy;
    return n;
}

rd_vk_result rd_readback_begin(rd_readback *rb, rd_cmd **cmd, char *err, size_t errlen)
{
    if (rb->open) {
        rd_vk_errorf(err, errlen, "A readback is already being recorded.");
        return RD_VK_ERR_VULKAN;
    }
    rd_readback_slot *s = NULL;
    for (int i = 0; i < RD_READBACK_SLOTS && !s; i++)
        if (slot_free(&rb->slots[i])) s = &rb->slots[i];
    if (!s) {
        rd_vk_errorf(err, errlen, "No free readback slot.");
        return RD_VK_ERR_VULKAN;
    }
    rd_vk_result r = rd_cmd_begin(rb->vk, &s->cmd, err, errlen);
    if (r != RD_VK_OK) return r;
    rb->open = s;
    *cmd = &s->cmd;
    return RD_VK_OK;
}

void rd_readback_abort(rd_readback *rb)
{
    if (!rb->open) return;
    rd_cmd_abandon(rb->vk, &rb->open->cmd);
    rb->open = NULL;
}

rd_vk_result rd_readback_finish(rd_readback *rb, const rd_buffer *src, size_t bytes, unsigned width,
                                unsigned height, const void *info, size_t info_size, char *err,
                                size_t errlen)
{
    const rd_readback_part part = {src, bytes};
    return rd_readback_finish_parts(rb, &part, 1, width, height, info, info_size, err, errlen);
}

rd_vk_result rd_readback_finish_parts(rd_readback *rb, const rd_readback_part *parts, unsigned n,
                                      unsigned width, unsigned height, const void *info,
                                      size_t info_size, char *err, size_t errlen)
{
    rd_readback_slot *s = rb->open;
    if (!s) {
        rd_vk_errorf(err, errlen, "rd_readback_finish without rd_readback_begin.");
        return RD_VK_ERR_VULKAN;
    }
    if (info_size > RD_READBACK_INFO_MAX || (info_size && !info)) {
        rd_readback_abort(rb);
        rd_vk_errorf(err, errlen, "Readback record of %zu bytes (at most %d).", info_size,
                     RD_READBACK_INFO_MAX);
        return RD_VK_ERR_UNSUPPORTED;
    }
    size_t bytes = 0;
    for (unsigned i = 0; i < n; i++) {
        if (parts[i].bytes > parts[i].src->size) {
            rd_readback_abort(rb);
            rd_vk_errorf(err, errlen, "Readback of %llu bytes from a %llu-byte buffer.",
                         (unsigned long long)parts[i].bytes,
                         (unsigned long long)parts[i].src->size);
            return RD_VK_ERR_VULKAN;
        }
        bytes += parts[i].bytes;
    }
    /* grow only: frames of several views share the ring, so sizes alternate */
    if (s->buffer.buffer == VK_NULL_HANDLE || s->buffer.size < bytes) {
        rd_buffer_destroy(rb->vk, &s->buffer);
        rd_vk_result r =
            rd_buffer_create(rb->vk, &s->buffer, bytes, RD_MEMORY_READBACK, err, errlen);
        if (r != RD_VK_OK) {
            rd_readback_abort(rb);
            return r;
        }
    }
    rb->open = NULL;
    if (bytes > 0) {
        /* the frame's passes (recorded before) finish writing src first */
        VkMemoryBarrier before = {
            .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
            .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT,
            .dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT,
        };
        vkCmdPipelineBarrier(s->cmd.cb, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                             VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before, 0, NULL, 0, NULL);
        VkDeviceSize at = 0;
        for (unsigned i = 0; i < n; i++) {
            if (!parts[i].bytes) continue;
            VkBufferCopy region = {.srcOffset = 0, .dstOffset = at, .size = parts[i].bytes};
            vkCmdCopyBuffer(s->cmd.cb, parts[i].src->buffer, s->buffer.buffer, 1, &region);
            at += parts[i].bytes;
        }
    }
    /* the copy's writes become visible to the host; and every later command (the next frame's
     * passes writing src) waits for the copy to have read src */
    VkMemoryBarrier mb = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_HOST_READ_BIT,
    };
    vkCmdPipelineBarrier(s->cmd.cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT |
                             VK_PIPELINE_STAGE_TRANSFER_BIT,
                         0, 1, &mb, 0, NULL, 0, NULL);
    VkResult vr = vkEndCommandBuffer(s->cmd.cb);
    if (vr == VK_SUCCESS) {
        VkSubmitInfo si = {
            .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
            .commandBufferCount = 1,
            .pCommandBuffers = &s->cmd.cb,
        };
        vr = vkQueueSubmit(rb->vk->queue, 1, &si, s->cmd.fence);
    }
    if (vr != VK_SUCCESS) {
        slot_release_cmd(rb->vk, s);
        return rd_vk_fail(rb->vk, vr, "readback submit", err, errlen);
    }
    s->busy = true;
    s->seq = rb->next_seq++;
    s->width = width;
    s->height = height;
    s->bytes = bytes;
    s->info_size = info_size;
    memset(s->info, 0, sizeof s->info);
    if (info_size) memcpy(s->info, info, info_size);
    return RD_VK_OK;
}

rd_vk_result rd_readback_submit(rd_readback *rb, const rd_buffer *src, size_t bytes, unsigned width,
                                unsigned height, const void *info, size_t info_size, char *err,
                                size_t errlen)
{
    rd_cmd *cmd;
    rd_vk_result r = rd_readback_begin(rb, &cmd, err, errlen);
    return r == RD_VK_OK
               ? rd_readback_finish(rb, src, bytes, width, height, info, info_size, err, errlen)
               : r;
}

static rd_readback_slot *oldest(rd_readback *rb)
{
    rd_readback_slot *o = NULL;
    for (int i = 0; i < RD_READBACK_SLOTS; i++) {
        rd_readback_slot *s = &rb->slots[i];
        if (s->busy && (!o || s->seq < o->seq)) o = s;
    }
    return o;
}

rd_vk_result rd_readback_poll(rd_readback *rb, uint64_t timeout_ns, rd_readback_fn fn, void *user,
                              char *err, size_t errlen)
{
    for (rd_readback_slot *s = oldest(rb); s; s = oldest(rb)) {
        VkResult vr = timeout_ns
                          ? vkWaitForFences(rb->vk->device, 1, &s->cmd.fence, VK_TRUE, timeout_ns)
                          : vkGetFenceStatus(rb->vk->device, s->cmd.fence);
        timeout_ns = 0;
        if (vr == VK_NOT_READY || vr == VK_TIMEOUT) return RD_VK_OK;
        if (vr != VK_SUCCESS) {
            slot_release_cmd(rb->vk, s);
            return rd_vk_fail(rb->vk, vr, "readback fence", err, errlen);
        }
        slot_release_cmd(rb->vk, s);
        if (!(s->buffer.memory_flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)) {
            VkMappedMemoryRange range = {
                .sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                .memory = s->buffer.memory,
                .offset = 0,
                .size = VK_WHOLE_SIZE,
            };
            vr = vkInvalidateMappedMemoryRanges(rb->vk->device, 1, &range);
            if (vr != VK_SUCCESS)
                return rd_vk_fail(rb->vk, vr, "vkInvalidateMappedMemoryRanges", err, errlen);
        }
        unsigned index = (unsigned)(s - rb->slots);
        if (fn(user, s->info, s->width, s->height, (const uint8_t *)s->buffer.mapped, s->bytes,
               index))
            atomic_store_explicit(&s->leased, true, memory_order_relaxed);
    }
    return RD_VK_OK;
}
