/* vk_buffer.c: device-address buffers, memory type choice and blocking transfers. */
#include "renderer/vk/vk_buffer.h"

#include "renderer/vk/vk_compute.h"

#include <string.h>

#define STAGING_CHUNK ((VkDeviceSize)64 << 20)

/* One acceptable memory type: all of `need`, none of `avoid`. */
typedef struct mem_choice {
    VkMemoryPropertyFlags need;
    VkMemoryPropertyFlags avoid;
} mem_choice;

#define HV VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT
#define HC VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
#define HCACHED VK_MEMORY_PROPERTY_HOST_CACHED_BIT
#define DL VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT

/* Candidates in order of preference; allocation falls through to the next one when a heap is
 * full (e.g. a small non-ReBAR BAR heap). */
static const mem_choice choices_device[] = {{DL, HV}, {DL, 0}, {0, 0}};
static const mem_choice choices_upload[] = {{HV | HC | DL, 0}, {HV | HC, 0}};
static const mem_choice choices_readback[] = {
    {HV | HCACHED | HC, 0}, {HV | HCACHED, 0}, {HV | HC, 0}};

static int find_type(const rd_vk *vk, uint32_t bits, mem_choice c, uint32_t tried)
{
    for (uint32_t i = 0; i < vk->memory.memoryTypeCount; i++) {
        VkMemoryPropertyFlags f = vk->memory.memoryTypes[i].propertyFlags;
        if (!(bits & (1u << i)) || (tried & (1u << i))) continue;
        if ((f & c.need) == c.need && !(f & c.avoid)) return (int)i;
    }
    return -1;
}

static const char *memory_name(rd_memory where)
{
    switch (where) {
    case RD_MEMORY_DEVICE:
        return "device";
    case RD_MEMORY_UPLOAD:
        return "upload";
    case RD_MEMORY_READBACK:
        return "readback";
    }
    return "unknown";
}

rd_vk_result rd_buffer_create(rd_vk *vk, rd_buffer *b, VkDeviceSize size, rd_memory where,
                              char *err, size_t errlen)
{
    return rd_buffer_create_usage(vk, b, size, where, 0, err, errlen);
}

rd_vk_result rd_buffer_create_usage(rd_vk *vk, rd_buffer *b, VkDeviceSize size, rd_memory where,
                                    VkBufferUsageFlags extra_usage, char *err, size_t errlen)
{
    memset(b, 0, sizeof *b);
    if (size == 0) size = 16;
    const mem_choice *choices;
    size_t nchoices;
    switch (where) {
    case RD_MEMORY_DEVICE:
        choices = choices_device;
        nchoices = sizeof choices_device / sizeof choices_device[0];
        break;
    case RD_MEMORY_UPLOAD:
        choices = choices_upload;
        nchoices = sizeof choices_upload / sizeof choices_upload[0];
        break;
    case RD_MEMORY_READBACK:
        choices = choices_readback;
        nchoices = sizeof choices_readback / sizeof choices_readback[0];
        break;
    default:
        rd_vk_errorf(err, errlen, "Unknown buffer memory kind %d.", (int)where);
        return RD_VK_ERR_VULKAN;
    }

    VkBufferCreateInfo bci = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = size,
        .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                 VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT |
                 VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | extra_usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkResult r = vkCreateBuffer(vk->device, &bci, NULL, &b->buffer);
    if (r != VK_SUCCESS) {
        b->buffer = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreateBuffer", err, errlen);
    }
    b->size = size;
    b->where = where;

    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(vk->device, b->buffer, &req);
    VkMemoryAllocateFlagsInfo flags = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO,
        .flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT,
    };
    VkMemoryAllocateInfo mai = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .pNext = &flags,
        .allocationSize = req.size,
    };
    uint32_t tried = 0;
    r = VK_ERROR_OUT_OF_DEVICE_MEMORY;
    bool any_type = false;
    for (size_t c = 0; c < nchoices && !b->memory; c++) {
        int type;
        while (!b->memory && (type = find_type(vk, req.memoryTypeBits, choices[c], tried)) >= 0) {
            tried |= 1u << type;
            any_type = true;
            VkMemoryType mt = vk->memory.memoryTypes[type];
            if (req.size > vk->memory.memoryHeaps[mt.heapIndex].size) {
                r = VK_ERROR_OUT_OF_DEVICE_MEMORY;
                continue;
            }
            mai.memoryTypeIndex = (uint32_t)type;
            r = vkAllocateMemory(vk->device, &mai, NULL, &b->memory);
            if (r == VK_SUCCESS) {
                b->memory_flags = mt.propertyFlags;
                b->alloc_size = req.size;
            } else {
                b->memory = VK_NULL_HANDLE;
                if (r != VK_ERROR_OUT_OF_DEVICE_MEMORY && r != VK_ERROR_OUT_OF_HOST_MEMORY)
                    break; /* a real error, not a full heap */
            }
        }
        if (!b->memory && r != VK_ERROR_OUT_OF_DEVICE_MEMORY && r != VK_ERROR_OUT_OF_HOST_MEMORY)
            break;
    }
    if (!b->memory) {
        rd_vk_result rc;
        if (!any_type) {
            rd_vk_errorf(err, errlen, "No memory type suits a %s buffer of %llu bytes.",
                         memory_name(where), (unsigned long long)size);
            rc = RD_VK_ERR_UNSUPPORTED;
        } else {
            rc = rd_vk_fail(vk, r, "vkAllocateMemory", err, errlen);
        }
        rd_buffer_destroy(vk, b);
        return rc;
    }

    r = vkBindBufferMemory(vk->device, b->buffer, b->memory, 0);
    if (r != VK_SUCCESS) {
        rd_buffer_destroy(vk, b);
        return rd_vk_fail(vk, r, "vkBindBufferMemory", err, errlen);
    }
    VkBufferDeviceAddressInfo ai = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO,
        .buffer = b->buffer,
    };
    b->address = vkGetBufferDeviceAddress(vk->device, &ai);

    if (where != RD_MEMORY_DEVICE) {
        r = vkMapMemory(vk->device, b->memory, 0, VK_WHOLE_SIZE, 0, &b->mapped);
        if (r != VK_SUCCESS) {
            b->mapped = NULL;
            rd_buffer_destroy(vk, b);
            return rd_vk_fail(vk, r, "vkMapMemory", err, errlen);
        }
    }
    return RD_VK_OK;
}

void rd_buffer_destroy(rd_vk *vk, rd_buffer *b)
{
    if (!b) return;
    if (vk && vk->device) {
        if (b->mapped) vkUnmapMemory(vk->device, b->memory);
        if (b->buffer) vkDestroyBuffer(vk->device, b->buffer, NULL);
        if (b->memory) vkFreeMemory(vk->device, b->memory, NULL);
    }
    memset(b, 0, sizeof *b);
}

/* ---- host access to mapped memory ---------------------------------------------------------- */

/* The atom-aligned range covering [offset, offset + size) of b's allocation. */
static VkMappedMemoryRange atom_range(const rd_vk *vk, const rd_buffer *b, VkDeviceSize offset,
                                      VkDeviceSize size)
{
    VkDeviceSize atom = vk->properties.limits.nonCoherentAtomSize;
    if (atom == 0) atom = 1;
    VkDeviceSize start = offset / atom * atom;
    VkDeviceSize end = (offset + size + atom - 1) / atom * atom;
    VkMappedMemoryRange range = {
        .sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
        .memory = b->memory,
        .offset = start,
        .size = end >= b->alloc_size ? VK_WHOLE_SIZE : end - start,
    };
    return range;
}

static bool coherent(const rd_buffer *b)
{
    return (b->memory_flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
}

static rd_vk_result check_range(const rd_buffer *b, VkDeviceSize offset, VkDeviceSize size,
                                const char *what, char *err, size_t errlen)
{
    if (!b->buffer) {
        rd_vk_errorf(err, errlen, "%s: the buffer was not created.", what);
        return RD_VK_ERR_VULKAN;
    }
    if (offset > b->size || size > b->size - offset) {
        rd_vk_errorf(err, errlen,
                     "%s: range of %llu bytes at offset %llu exceeds the buffer size %llu.", what,
                     (unsigned long long)size, (unsigned long long)offset,
                     (unsigned long long)b->size);
        return RD_VK_ERR_VULKAN;
    }
    return RD_VK_OK;
}

/* Makes transfer writes available to later compute and transfer work (also in later
 * submissions, which follow in submission order) and to the host. */
static void transfer_done_barrier(VkCommandBuffer cb)
{
    VkMemoryBarrier mb = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                         VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT |
                         VK_ACCESS_HOST_READ_BIT,
    };
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                             VK_PIPELINE_STAGE_HOST_BIT,
                         0, 1, &mb, 0, NULL, 0, NULL);
}

/* Copies size bytes between two buffers with a one-shot command buffer and waits. */
static rd_vk_result copy_wait(rd_vk *vk, VkBuffer src, VkDeviceSize src_off, VkBuffer dst,
                              VkDeviceSize dst_off, VkDeviceSize size, char *err, size_t errlen)
{
    rd_cmd c;
    rd_vk_result rc = rd_cmd_begin(vk, &c, err, errlen);
    if (rc != RD_VK_OK) return rc;
    VkBufferCopy region = {.srcOffset = src_off, .dstOffset = dst_off, .size = size};
    vkCmdCopyBuffer(c.cb, src, dst, 1, &region);
    transfer_done_barrier(c.cb);
    return rd_cmd_submit_wait(vk, &c, err, errlen);
}

/* Moves size bytes between host memory and device buffer gpu at offset through a host-visible
 * staging buffer, one chunk at a time: from `up` into gpu when up is given, else from gpu into
 * `down`. */
static rd_vk_result staged(rd_vk *vk, VkBuffer gpu, VkDeviceSize offset, const void *up, void *down,
                           VkDeviceSize size, char *err, size_t errlen)
{
    rd_buffer staging;
    VkDeviceSize chunk = size < STAGING_CHUNK ? size : STAGING_CHUNK;
    rd_vk_result rc = rd_buffer_create(vk, &staging, chunk,
                                       up ? RD_MEMORY_UPLOAD : RD_MEMORY_READBACK, err, errlen);
    if (rc != RD_VK_OK) return rc;
    for (VkDeviceSize done = 0; done < size && rc == RD_VK_OK; done += chunk) {
        VkDeviceSize n = size - done < chunk ? size - done : chunk;
        if (up) {
            rc = rd_buffer_upload(vk, &staging, 0, (const char *)up + done, n, err, errlen);
            if (rc == RD_VK_OK)
                rc = copy_wait(vk, staging.buffer, 0, gpu, offset + done, n, err, errlen);
        } else {
            rc = copy_wait(vk, gpu, offset + done, staging.buffer, 0, n, err, errlen);
            if (rc == RD_VK_OK)
                rc = rd_buffer_download(vk, &staging, 0, (char *)down + done, n, err, errlen);
        }
    }
    rd_buffer_destroy(vk, &staging);
    return rc;
}

rd_vk_result rd_buffer_upload(rd_vk *vk, rd_buffer *dst, VkDeviceSize offset, const void *src,
                              VkDeviceSize size, char *err, size_t errlen)
{
    rd_vk_result rc = check_range(dst, offset, size, "rd_buffer_upload", err, errlen);
    if (rc != RD_VK_OK || size == 0) return rc;

    if (dst->mapped) {
        memcpy((char *)dst->mapped + offset, src, (size_t)size);
        if (!coherent(dst)) {
            VkMappedMemoryRange range = atom_range(vk, dst, offset, size);
            VkResult r = vkFlushMappedMemoryRanges(vk->device, 1, &range);
            if (r != VK_SUCCESS) return rd_vk_fail(vk, r, "vkFlushMappedMemoryRanges", err, errlen);
        }
        return RD_VK_OK;
    }

    return staged(vk, dst->buffer, offset, src, NULL, size, err, errlen);
}

rd_vk_result rd_buffer_download(rd_vk *vk, const rd_buffer *src, VkDeviceSize offset, void *dst,
                                VkDeviceSize size, char *err, size_t errlen)
{
    rd_vk_result rc = check_range(src, offset, size, "rd_buffer_download", err, errlen);
    if (rc != RD_VK_OK || size == 0) return rc;

    if (src->mapped) {
        if (!coherent(src)) {
            VkMappedMemoryRange range = atom_range(vk, src, offset, size);
            VkResult r = vkInvalidateMappedMemoryRanges(vk->device, 1, &range);
            if (r != VK_SUCCESS)
                return rd_vk_fail(vk, r, "vkInvalidateMappedMemoryRanges", err, errlen);
        }
        memcpy(dst, (const char *)src->mapped + offset, (size_t)size);
        return RD_VK_OK;
    }

    return staged(vk, src->buffer, offset, NULL, dst, size, err, errlen);
}

rd_vk_result rd_buffer_fill(rd_vk *vk, rd_buffer *b, uint32_t word, char *err, size_t errlen)
{
    rd_vk_result rc = check_range(b, 0, 0, "rd_buffer_fill", err, errlen);
    if (rc != RD_VK_OK) return rc;
    rd_cmd c;
    rc = rd_cmd_begin(vk, &c, err, errlen);
    if (rc != RD_VK_OK) return rc;
    /* VK_WHOLE_SIZE fills floor(size / 4) words; rd_buffer sizes are normally multiples of 4. */
    vkCmdFillBuffer(c.cb, b->buffer, 0, VK_WHOLE_SIZE, word);
    transfer_done_barrier(c.cb);
    return rd_cmd_submit_wait(vk, &c, err, errlen);
}
