/* vk_compute.c: compute pipelines, one-shot command buffers and timestamp queries. */
#include "renderer/vk/vk_compute.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

/* One fence wait; lavapipe can take minutes on big dispatches, so waits repeat. */
#define WAIT_STEP_NS (60ull * 1000 * 1000 * 1000)
#define WAIT_STEPS 10 /* 10 minutes in all */

/* ---- pipelines ------------------------------------------------------------------------------ */

/* Pipelines are kept and shared: rd_pipeline_create of a SPIR-V and push size that the device
 * already has a pipeline for hands out that pipeline again, and rd_pipeline_destroy only lets go
 * of it; rd_vk_destroy destroys them all. Each renderer, world and test fixture creates its
 * passes' pipelines, and lavapipe compiles each one with LLVM (it has no pipeline cache): 1.1 s
 * for a renderer on a 2-core machine, 3.5 s under AddressSanitizer, paid again by every image a
 * test renders and by every world a daemon makes. A device holds a few hundred at most (each
 * pass's SPIR-V, and on a CPU device its masked-lanes variant). */
static uint64_t spirv_hash(const uint32_t *spirv, size_t bytes)
{
    uint64_t h = 0xcbf29ce484222325ull; /* FNV-1a, 64 bits */
    const unsigned char *b = (const unsigned char *)spirv;
    for (size_t i = 0; i < bytes; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

/* The shared entry holding pipeline, or NULL. Called with pipelines_lock held. */
static rd_shared_pipeline *shared_find(rd_vk *vk, VkPipeline pipeline)
{
    for (size_t i = 0; i < vk->pipeline_count; i++)
        if (vk->pipelines[i].pipeline == pipeline) return &vk->pipelines[i];
    return NULL;
}

/* Creates p's objects (not shared yet). */
static rd_vk_result pipeline_build(rd_vk *vk, rd_pipeline *p, const uint32_t *spirv,
                                   size_t spirv_bytes, uint32_t push_size, char *err, size_t errlen)
{
    char what[160];
    VkShaderModuleCreateInfo smci = {
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
        .codeSize = spirv_bytes,
        .pCode = spirv,
    };
    VkResult r = vkCreateShaderModule(vk->device, &smci, NULL, &p->module);
    if (r != VK_SUCCESS) {
        p->module = VK_NULL_HANDLE;
        snprintf(what, sizeof what, "vkCreateShaderModule (%s)", p->name);
        goto fail;
    }

    VkPushConstantRange range = {
        .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT,
        .offset = 0,
        .size = push_size,
    };
    VkPipelineLayoutCreateInfo plci = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .pushConstantRangeCount = push_size ? 1u : 0u,
        .pPushConstantRanges = push_size ? &range : NULL,
    };
    r = vkCreatePipelineLayout(vk->device, &plci, NULL, &p->layout);
    if (r != VK_SUCCESS) {
        p->layout = VK_NULL_HANDLE;
        snprintf(what, sizeof what, "vkCreatePipelineLayout (%s)", p->name);
        goto fail;
    }

    VkComputePipelineCreateInfo cpci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage =
            {
                .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                .module = p->module,
                .pName = "main",
            },
        .layout = p->layout,
    };
    r = vkCreateComputePipelines(vk->device, VK_NULL_HANDLE, 1, &cpci, NULL, &p->pipeline);
    if (r != VK_SUCCESS) {
        p->pipeline = VK_NULL_HANDLE;
        snprintf(what, sizeof what, "vkCreateComputePipelines (%s)", p->name);
        goto fail;
    }
    return RD_VK_OK;

fail:;
    rd_vk_result rc = rd_vk_fail(vk, r, what, err, errlen);
    if (p->layout) vkDestroyPipelineLayout(vk->device, p->layout, NULL);
    if (p->module) vkDestroyShaderModule(vk->device, p->module, NULL);
    p->layout = VK_NULL_HANDLE;
    p->module = VK_NULL_HANDLE;
    return rc;
}

rd_vk_result rd_pipeline_create(rd_vk *vk, rd_pipeline *p, const char *name, const uint32_t *spirv,
                                size_t spirv_bytes, uint32_t push_size, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->name = name ? name : "(unnamed)";
    if (!spirv || spirv_bytes == 0 || spirv_bytes % 4 != 0) {
        rd_vk_errorf(err, errlen,
                     "Pipeline %s: SPIR-V of %zu bytes is not a whole number of words.", p->name,
                     spirv_bytes);
        return RD_VK_ERR_VULKAN;
    }
    if (push_size % 4 != 0 || push_size > vk->properties.limits.maxPushConstantsSize) {
        rd_vk_errorf(err, errlen,
                     "Pipeline %s: push constants of %u bytes (must be a multiple of 4, at most "
                     "%u).",
                     p->name, push_size, vk->properties.limits.maxPushConstantsSize);
        return RD_VK_ERR_UNSUPPORTED;
    }
    p->push_size = push_size;
    uint64_t hash = spirv_hash(spirv, spirv_bytes);
    rd_vk_result rc = RD_VK_OK;
    /* held while a new pipeline compiles: another thread asking for the same one waits for it */
    pthread_mutex_lock(&vk->pipelines_lock);
    rd_shared_pipeline *sp = NULL;
    for (size_t i = 0; i < vk->pipeline_count && !sp; i++) {
        rd_shared_pipeline *e = &vk->pipelines[i];
        if (e->hash == hash && e->spirv_bytes == spirv_bytes && e->push_size == push_size) sp = e;
    }
    if (!sp && vk->pipeline_count == vk->pipeline_cap) {
        size_t cap = vk->pipeline_cap ? 2 * vk->pipeline_cap : 64;
        rd_shared_pipeline *grown = realloc(vk->pipelines, cap * sizeof *grown);
        if (!grown) {
            rd_vk_errorf(err, errlen, "Pipeline %s: out of memory.", p->name);
            rc = RD_VK_ERR_VULKAN;
        } else {
            vk->pipelines = grown;
            vk->pipeline_cap = cap;
        }
    }
    if (!sp && rc == RD_VK_OK) {
        rc = pipeline_build(vk, p, spirv, spirv_bytes, push_size, err, errlen);
        if (rc == RD_VK_OK) {
            sp = &vk->pipelines[vk->pipeline_count++];
            *sp = (rd_shared_pipeline){.hash = hash,
                                       .spirv_bytes = spirv_bytes,
                                       .push_size = push_size,
                                       .module = p->module,
                                       .layout = p->layout,
                                       .pipeline = p->pipeline};
        }
    }
    if (sp) {
        sp->refs++;
        p->module = sp->module;
        p->layout = sp->layout;
        p->pipeline = sp->pipeline;
    }
    pthread_mutex_unlock(&vk->pipelines_lock);
    if (rc != RD_VK_OK) p->push_size = 0;
    return rc;
}

void rd_pipeline_destroy(rd_vk *vk, rd_pipeline *p)
{
    if (!p) return;
    if (vk && vk->device && p->pipeline) {
        pthread_mutex_lock(&vk->pipelines_lock);
        rd_shared_pipeline *sp = shared_find(vk, p->pipeline);
        if (sp && sp->refs > 0) sp->refs--; /* kept for the next rd_pipeline_create */
        pthread_mutex_unlock(&vk->pipelines_lock);
    }
    p->pipeline = VK_NULL_HANDLE;
    p->layout = VK_NULL_HANDLE;
    p->module = VK_NULL_HANDLE;
    p->push_size = 0;
}

static rd_pipeline *member(void *owner, const rd_pipeline_desc *d)
{
    return (rd_pipeline *)((char *)owner + d->offset);
}

rd_vk_result rd_pipelines_create(rd_vk *vk, void *owner, const rd_pipeline_desc *table,
                                 size_t count, char *err, size_t errlen)
{
    for (size_t i = 0; i < count; i++) {
        const rd_pipeline_desc *d = &table[i];
        bool masked = vk->masked_lanes && d->spirv_masked;
        rd_vk_result r = rd_pipeline_create(
            vk, member(owner, d), d->name, masked ? d->spirv_masked : d->spirv,
            masked ? d->spirv_masked_bytes : d->spirv_bytes, d->push_size, err, errlen);
        if (r != RD_VK_OK) {
            rd_pipelines_destroy(vk, owner, table, i);
            return r;
        }
    }
    return RD_VK_OK;
}

void rd_pipelines_destroy(rd_vk *vk, void *owner, const rd_pipeline_desc *table, size_t count)
{
    for (size_t i = count; i-- > 0;)
        rd_pipeline_destroy(vk, member(owner, &table[i]));
}

/* ---- one-shot command buffers ------------------------------------------------------------- */

/* A finished (or never submitted) command buffer and its fence go back to the spares. */
static void cmd_free(rd_vk *vk, rd_cmd *c)
{
    if (c->cb && c->fence && vk->spare_count < RD_VK_SPARE_CMDS && !vk->device_lost) {
        vk->spare_cb[vk->spare_count] = c->cb;
        vk->spare_fence[vk->spare_count] = c->fence;
        vk->spare_count++;
    } else {
        if (c->fence) vkDestroyFence(vk->device, c->fence, NULL);
        if (c->cb) vkFreeCommandBuffers(vk->device, vk->command_pool, 1, &c->cb);
    }
    c->fence = VK_NULL_HANDLE;
    c->cb = VK_NULL_HANDLE;
}

void rd_cmd_release(rd_vk *vk, rd_cmd *c)
{
    cmd_free(vk, c);
}

void rd_cmd_abandon(rd_vk *vk, rd_cmd *c)
{
    if (c->cb) vkEndCommandBuffer(c->cb);
    cmd_free(vk, c);
}

rd_vk_result rd_cmd_begin(rd_vk *vk, rd_cmd *c, char *err, size_t errlen)
{
    memset(c, 0, sizeof *c);
    if (vk->device_lost) {
        rd_vk_errorf(err, errlen, "The Vulkan device was lost earlier.");
        return RD_VK_ERR_DEVICE_LOST;
    }
    VkResult r = VK_SUCCESS;
    if (vk->spare_count) {
        /* the pool resets buffers: vkBeginCommandBuffer starts this one afresh */
        vk->spare_count--;
        c->cb = vk->spare_cb[vk->spare_count];
        c->fence = vk->spare_fence[vk->spare_count];
        r = vkResetFences(vk->device, 1, &c->fence);
        if (r != VK_SUCCESS) {
            vkDestroyFence(vk->device, c->fence, NULL);
            vkFreeCommandBuffers(vk->device, vk->command_pool, 1, &c->cb);
            memset(c, 0, sizeof *c);
            return rd_vk_fail(vk, r, "vkResetFences", err, errlen);
        }
    } else {
        VkCommandBufferAllocateInfo ai = {
            .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
            .commandPool = vk->command_pool,
            .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
            .commandBufferCount = 1,
        };
        r = vkAllocateCommandBuffers(vk->device, &ai, &c->cb);
        if (r != VK_SUCCESS) {
            c->cb = VK_NULL_HANDLE;
            return rd_vk_fail(vk, r, "vkAllocateCommandBuffers", err, errlen);
        }
        VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        r = vkCreateFence(vk->device, &fci, NULL, &c->fence);
        if (r != VK_SUCCESS) {
            c->fence = VK_NULL_HANDLE;
            cmd_free(vk, c);
            return rd_vk_fail(vk, r, "vkCreateFence", err, errlen);
        }
    }
    VkCommandBufferBeginInfo bi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
        .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
    };
    r = vkBeginCommandBuffer(c->cb, &bi);
    if (r != VK_SUCCESS) {
        cmd_free(vk, c);
        return rd_vk_fail(vk, r, "vkBeginCommandBuffer", err, errlen);
    }
    /* Submissions may be in flight together (a view's frame while the next is recorded, a world
     * update after frames that read the probe field): every command buffer first waits for all
     * work submitted before it on the queue, so the GPU runs submissions one after another. */
    VkMemoryBarrier mb = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                         VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
    };
    vkCmdPipelineBarrier(c->cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &mb, 0, NULL, 0, NULL);
    return RD_VK_OK;
}

rd_vk_result rd_cmd_submit_wait(rd_vk *vk, rd_cmd *c, char *err, size_t errlen)
{
    if (!c->cb) {
        rd_vk_errorf(err, errlen, "rd_cmd_submit_wait: the command buffer was not begun.");
        return RD_VK_ERR_VULKAN;
    }
    VkResult r = vkEndCommandBuffer(c->cb);
    if (r != VK_SUCCESS) {
        cmd_free(vk, c);
        return rd_vk_fail(vk, r, "vkEndCommandBuffer", err, errlen);
    }
    VkSubmitInfo si = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
        .commandBufferCount = 1,
        .pCommandBuffers = &c->cb,
    };
    r = vkQueueSubmit(vk->queue, 1, &si, c->fence);
    if (r != VK_SUCCESS) {
        cmd_free(vk, c);
        return rd_vk_fail(vk, r, "vkQueueSubmit", err, errlen);
    }
    r = VK_TIMEOUT;
    for (int step = 0; step < WAIT_STEPS && r == VK_TIMEOUT; step++)
        r = vkWaitForFences(vk->device, 1, &c->fence, VK_TRUE, WAIT_STEP_NS);
    if (r == VK_TIMEOUT) {
        /* Still pending: the command buffer and fence cannot be freed safely, so they are
         * left to the pool and device teardown. */
        c->cb = VK_NULL_HANDLE;
        c->fence = VK_NULL_HANDLE;
        fprintf(stderr, "vulkan: vkWaitForFences failed: VK_TIMEOUT after %d s\n", WAIT_STEPS * 60);
        rd_vk_errorf(err, errlen,
                     "GPU work did not finish within %d seconds (vkWaitForFences returned "
                     "VK_TIMEOUT).",
                     WAIT_STEPS * 60);
        return RD_VK_ERR_VULKAN;
    }
    if (r != VK_SUCCESS) {
        rd_vk_result rc = rd_vk_fail(vk, r, "vkWaitForFences", err, errlen);
        if (r == VK_ERROR_DEVICE_LOST)
            cmd_free(vk, c); /* nothing is pending on a lost device */
        else {
            c->cb = VK_NULL_HANDLE;
            c->fence = VK_NULL_HANDLE;
        }
        return rc;
    }
    cmd_free(vk, c);
    return RD_VK_OK;
}

void rd_cmd_dispatch(rd_cmd *c, const rd_pipeline *p, const void *push, uint32_t gx, uint32_t gy,
                     uint32_t gz)
{
    vkCmdBindPipeline(c->cb, VK_PIPELINE_BIND_POINT_COMPUTE, p->pipeline);
    if (p->push_size && push)
        vkCmdPushConstants(c->cb, p->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, p->push_size, push);
    vkCmdDispatch(c->cb, gx, gy, gz);
}

void rd_cmd_dispatch_indirect(rd_cmd *c, const rd_pipeline *p, const void *push,
                              const rd_buffer *args, VkDeviceSize offset)
{
    vkCmdBindPipeline(c->cb, VK_PIPELINE_BIND_POINT_COMPUTE, p->pipeline);
    if (p->push_size && push)
        vkCmdPushConstants(c->cb, p->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, p->push_size, push);
    vkCmdDispatchIndirect(c->cb, args->buffer, offset);
}

void rd_cmd_barrier(rd_cmd *c)
{
    VkMemoryBarrier mb = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                         VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT |
                         VK_ACCESS_HOST_READ_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT,
    };
    vkCmdPipelineBarrier(c->cb,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                             VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                         0, 1, &mb, 0, NULL, 0, NULL);
}

/* ---- timestamps ----------------------------------------------------------------------------- */

rd_vk_result rd_timer_create(rd_vk *vk, rd_timer *t, char *err, size_t errlen)
{
    memset(t, 0, sizeof *t);
    if (vk->timestamp_period_ns <= 0.0) return RD_VK_OK; /* no timestamps: a no-op timer */
    VkQueryPoolCreateInfo qci = {
        .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
        .queryType = VK_QUERY_TYPE_TIMESTAMP,
        .queryCount = RD_TIMER_MAX,
    };
    VkResult r = vkCreateQueryPool(vk->device, &qci, NULL, &t->pool);
    if (r != VK_SUCCESS) {
        t->pool = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreateQueryPool", err, errlen);
    }
    return RD_VK_OK;
}

void rd_timer_destroy(rd_vk *vk, rd_timer *t)
{
    if (!t) return;
    if (t->pool && vk && vk->device) vkDestroyQueryPool(vk->device, t->pool, NULL);
    t->pool = VK_NULL_HANDLE;
    t->count = 0;
    t->valid = false;
}

void rd_timer_begin(rd_cmd *c, rd_timer *t)
{
    t->count = 0;
    t->valid = false;
    for (int i = 0; i < RD_TIMER_MAX; i++) {
        t->names[i] = NULL;
        t->ms[i] = 0.0;
    }
    if (!t->pool) return;
    vkCmdResetQueryPool(c->cb, t->pool, 0, RD_TIMER_MAX);
    vkCmdWriteTimestamp(c->cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, t->pool, 0);
    t->names[0] = "start";
    t->count = 1;
}

void rd_timer_mark(rd_cmd *c, rd_timer *t, const char *name)
{
    if (!t->pool || t->count == 0 || t->count >= RD_TIMER_MAX) return;
    rd_cmd_barrier(c);
    vkCmdWriteTimestamp(c->cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, t->pool, t->count);
    t->names[t->count] = name;
    t->count++;
}

rd_vk_result rd_timer_resolve(rd_vk *vk, rd_timer *t, char *err, size_t errlen)
{
    t->valid = false;
    if (!t->pool || t->count == 0) return RD_VK_OK;
    uint64_t stamps[RD_TIMER_MAX];
    VkResult r =
        vkGetQueryPoolResults(vk->device, t->pool, 0, t->count, sizeof(uint64_t) * t->count, stamps,
                              sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    if (r != VK_SUCCESS) return rd_vk_fail(vk, r, "vkGetQueryPoolResults", err, errlen);
    uint32_t bits = vk->timestamp_valid_bits;
    uint64_t mask = (bits == 0 || bits >= 64) ? ~0ull : ((1ull << bits) - 1);
    t->ms[0] = 0.0;
    for (uint32_t i = 1; i < t->count; i++) {
        uint64_t ticks = ((stamps[i] & mask) - (stamps[i - 1] & mask)) & mask; /* wraps */
        t->ms[i] = (double)ticks * vk->timestamp_period_ns * 1e-6;
    }
    t->valid = true;
    return RD_VK_OK;
}
