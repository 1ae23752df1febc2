#include "rt_driver.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* after stdint.h (through rt_driver.h): the generated headers declare uint32_t arrays */
#include "bench/rtb_rchit.spv.h"
#include "bench/rtb_rgen.spv.h"
#include "bench/rtb_rmiss.spv.h"

/* Device-level entry points of the two extensions (not exported by the loader). */
static struct {
    PFN_vkGetAccelerationStructureBuildSizesKHR build_sizes;
    PFN_vkCreateAccelerationStructureKHR create_as;
    PFN_vkDestroyAccelerationStructureKHR destroy_as;
    PFN_vkCmdBuildAccelerationStructuresKHR cmd_build;
    PFN_vkGetAccelerationStructureDeviceAddressKHR as_address;
    PFN_vkCreateRayTracingPipelinesKHR create_pipelines;
    PFN_vkGetRayTracingShaderGroupHandlesKHR group_handles;
    PFN_vkCmdTraceRaysKHR trace_rays;
} fn;

static const char *const EXTENSIONS[] = {
    VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
    VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME,
    VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME,
};

void rtb_driver_device_options(rtb_driver_features *f, rd_vk_options *o)
{
    memset(f, 0, sizeof *f);
    f->rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR;
    f->rt.rayTracingPipeline = VK_TRUE;
    f->as.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR;
    f->as.accelerationStructure = VK_TRUE;
    f->as.pNext = &f->rt;
    o->extra_extensions = EXTENSIONS;
    o->extra_extension_count = sizeof EXTENSIONS / sizeof EXTENSIONS[0];
    o->extra_features = &f->as;
}

void rtb_barrier_all(rd_cmd *c)
{
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT,
                          .dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT};
    vkCmdPipelineBarrier(c->cb, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &mb, 0, NULL, 0, NULL);
}

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a)
{
    return (v + a - 1) / a * a;
}

static bool load_functions(VkDevice dev)
{
#define LOAD(field, name) fn.field = (PFN_##name)vkGetDeviceProcAddr(dev, #name)
    LOAD(build_sizes, vkGetAccelerationStructureBuildSizesKHR);
    LOAD(create_as, vkCreateAccelerationStructureKHR);
    LOAD(destroy_as, vkDestroyAccelerationStructureKHR);
    LOAD(cmd_build, vkCmdBuildAccelerationStructuresKHR);
    LOAD(as_address, vkGetAccelerationStructureDeviceAddressKHR);
    LOAD(create_pipelines, vkCreateRayTracingPipelinesKHR);
    LOAD(group_handles, vkGetRayTracingShaderGroupHandlesKHR);
    LOAD(trace_rays, vkCmdTraceRaysKHR);
#undef LOAD
    return fn.build_sizes && fn.create_as && fn.destroy_as && fn.cmd_build && fn.as_address &&
           fn.create_pipelines && fn.group_handles && fn.trace_rays;
}

static rd_vk_result create_as(rtb_driver *d, VkAccelerationStructureTypeKHR type,
                              const rd_buffer *mem, VkDeviceSize offset, VkDeviceSize size,
                              VkAccelerationStructureKHR *out, char *err, size_t errlen)
{
    VkAccelerationStructureCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR,
        .buffer = mem->buffer,
        .offset = offset,
        .size = size,
        .type = type,
    };
    VkResult r = fn.create_as(d->vk->device, &ci, NULL, out);
    if (r != VK_SUCCESS) {
        *out = VK_NULL_HANDLE;
        return rd_vk_fail(d->vk, r, "vkCreateAccelerationStructureKHR", err, errlen);
    }
    return RD_VK_OK;
}

static VkDeviceAddress as_address(rtb_driver *d, VkAccelerationStructureKHR as)
{
    VkAccelerationStructureDeviceAddressInfoKHR ai = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR,
        .accelerationStructure = as};
    return fn.as_address(d->vk->device, &ai);
}

/* One BLAS per mesh from the copied pc_tri array, one TLAS over the scene's instances; both
 * built in one submission, timed. */
static rd_vk_result build_structures(rtb_driver *d, const rd_scene *s, const rd_gpu_scene *gs,
                                     char *err, size_t errlen)
{
    rd_vk *vk = d->vk;
    const VkBufferUsageFlags as_input =
        VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
    VkPhysicalDeviceAccelerationStructurePropertiesKHR asp = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR};
    VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                      .pNext = &asp};
    vkGetPhysicalDeviceProperties2(vk->physical, &p2);
    VkDeviceSize scratch_align = asp.minAccelerationStructureScratchOffsetAlignment;
    if (scratch_align == 0) scratch_align = 256;

    rd_vk_result res = rd_buffer_create_usage(vk, &d->verts, gs->tris.size, RD_MEMORY_DEVICE,
                                              as_input, err, errlen);
    if (res != RD_VK_OK) return res;

    uint32_t n = s->mesh_count;
    d->blas = calloc(n ? n : 1, sizeof *d->blas);
    VkAccelerationStructureGeometryKHR *geo = calloc(n ? n : 1, sizeof *geo);
    VkAccelerationStructureBuildGeometryInfoKHR *info = calloc(n ? n : 1, sizeof *info);
    VkAccelerationStructureBuildRangeInfoKHR *range = calloc(n ? n : 1, sizeof *range);
    const VkAccelerationStructureBuildRangeInfoKHR **ranges = calloc(n ? n : 1, sizeof *ranges);
    VkDeviceSize *as_off = calloc(n + 1, sizeof *as_off), *scr_off = calloc(n + 1, sizeof *scr_off);
    pc_instance *src = calloc(s->instance_count ? s->instance_count : 1, sizeof *src);
    if (!d->blas || !geo || !info || !range || !ranges || !as_off || !scr_off || !src) abort();
    d->blas_count = n;

    VkDeviceSize as_total = 0, scratch_total = 0, tri_base = 0;
    uint32_t built = 0;
    for (uint32_t m = 0; m < n; m++) {
        uint32_t count = s->meshes[m].tri_count;
        geo[m] = (VkAccelerationStructureGeometryKHR){
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
            .geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR,
            .flags = VK_GEOMETRY_OPAQUE_BIT_KHR,
            .geometry.triangles = {
                .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR,
                .vertexFormat = VK_FORMAT_R32G32B32_SFLOAT,
                .vertexData.deviceAddress = d->verts.address + tri_base * sizeof(pc_tri),
                .vertexStride = sizeof(pc_tri) / 3, /* v0, v1, v2 are vec4s */
                .maxVertex = count ? 3 * count - 1 : 0,
                .indexType = VK_INDEX_TYPE_NONE_KHR,
            }};
        tri_base += count;
        info[m] = (VkAccelerationStructureBuildGeometryInfoKHR){
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
            .type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR,
            .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR,
            .mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
            .geometryCount = 1,
            .pGeometries = &geo[m],
        };
        range[m] = (VkAccelerationStructureBuildRangeInfoKHR){.primitiveCount = count};
        ranges[m] = &range[m];
        VkAccelerationStructureBuildSizesInfoKHR sz = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
        fn.build_sizes(vk->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info[m],
                       &count, &sz);
        as_off[m] = as_total;
        scr_off[m] = scratch_total;
        as_total = align_up(as_total + sz.accelerationStructureSize, 256);
        scratch_total = align_up(scratch_total + sz.buildScratchSize, scratch_align);
        as_off[m + 1] = as_total;
    }
    if (gs->tris.size < tri_base * sizeof(pc_tri)) {
        snprintf(err, errlen, "the scene's triangle buffer is smaller than its meshes");
        res = RD_VK_ERR_VULKAN;
        goto done;
    }
    res =
        rd_buffer_create_usage(vk, &d->blas_mem, as_total, RD_MEMORY_DEVICE,
                               VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, err, errlen);
    for (uint32_t m = 0; m < n && res == RD_VK_OK; m++) {
        if (range[m].primitiveCount == 0) continue;
        res = create_as(d, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, &d->blas_mem, as_off[m],
                        as_off[m + 1] - as_off[m], &d->blas[m], err, errlen);
        if (res != RD_VK_OK) break;
        info[built] = info[m];
        info[built].dstAccelerationStructure = d->blas[m];
        ranges[built] = &range[m];
        built++;
    }
    if (res != RD_VK_OK) goto done;

    /* TLAS over the renderer's own instance transforms */
    uint32_t ni = s->instance_count;
    res =
        rd_buffer_download(vk, &gs->instances, 0, src, (VkDeviceSize)ni * sizeof *src, err, errlen);
    if (res == RD_VK_OK)
        res = rd_buffer_create_usage(vk, &d->instances,
                                     (VkDeviceSize)ni * sizeof(VkAccelerationStructureInstanceKHR),
                                     RD_MEMORY_UPLOAD, as_input, err, errlen);
    if (res != RD_VK_OK) goto done;
    VkAccelerationStructureInstanceKHR *inst = d->instances.mapped;
    uint32_t placed = 0;
    for (uint32_t i = 0; i < ni; i++) {
        uint32_t mesh = src[i].info.y;
        if (mesh >= n || !d->blas[mesh]) continue;
        VkAccelerationStructureInstanceKHR *o = &inst[placed++];
        memset(o, 0, sizeof *o);
        for (int r = 0; r < 3; r++) {
            o->transform.matrix[r][0] = src[i].object_to_world[r].x;
            o->transform.matrix[r][1] = src[i].object_to_world[r].y;
            o->transform.matrix[r][2] = src[i].object_to_world[r].z;
            o->transform.matrix[r][3] = src[i].object_to_world[r].w;
        }
        o->instanceCustomIndex = i;
        o->mask = 0xff;
        o->flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
        o->accelerationStructureReference = as_address(d, d->blas[mesh]);
    }
    VkAccelerationStructureGeometryKHR tgeo = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR,
        .flags = VK_GEOMETRY_OPAQUE_BIT_KHR,
        .geometry.instances = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR,
            .data.deviceAddress = d->instances.address}};
    VkAccelerationStructureBuildGeometryInfoKHR tinfo = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
        .type = VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR,
        .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR,
        .mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
        .geometryCount = 1,
        .pGeometries = &tgeo,
    };
    VkAccelerationStructureBuildSizesInfoKHR tsz = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
    fn.build_sizes(vk->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &tinfo, &placed,
                   &tsz);
    res =
        rd_buffer_create_usage(vk, &d->tlas_mem, tsz.accelerationStructureSize, RD_MEMORY_DEVICE,
                               VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, err, errlen);
    if (res == RD_VK_OK)
        res = create_as(d, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, &d->tlas_mem, 0,
                        tsz.accelerationStructureSize, &d->tlas, err, errlen);
    VkDeviceSize scratch_size =
        scratch_total > tsz.buildScratchSize ? scratch_total : tsz.buildScratchSize;
    if (res == RD_VK_OK)
        res = rd_buffer_create(vk, &d->scratch, scratch_size + scratch_align, RD_MEMORY_DEVICE, err,
                               errlen);
    if (res != RD_VK_OK) goto done;
    VkDeviceAddress scratch = align_up(d->scratch.address, scratch_align);
    for (uint32_t m = 0, b = 0; m < n; m++)
        if (d->blas[m]) info[b++].scratchData.deviceAddress = scratch + scr_off[m];
    tinfo.dstAccelerationStructure = d->tlas;
    tinfo.scratchData.deviceAddress = scratch;
    VkAccelerationStructureBuildRangeInfoKHR trange = {.primitiveCount = placed};
    const VkAccelerationStructureBuildRangeInfoKHR *tranges = &trange;
    d->as_bytes = as_total + tsz.accelerationStructureSize;

    rd_timer timer = {0};
    rd_cmd c = {0};
    res = rd_timer_create(vk, &timer, err, errlen);
    if (res == RD_VK_OK) res = rd_cmd_begin(vk, &c, err, errlen);
    if (res == RD_VK_OK) {
        VkBufferCopy copy = {.size = gs->tris.size};
        vkCmdCopyBuffer(c.cb, gs->tris.buffer, d->verts.buffer, 1, &copy);
        rtb_barrier_all(&c);
        rd_timer_begin(&c, &timer);
        if (built) fn.cmd_build(c.cb, built, info, ranges);
        rtb_barrier_all(&c);
        rd_timer_mark(&c, &timer, "blas");
        fn.cmd_build(c.cb, 1, &tinfo, &tranges);
        rtb_barrier_all(&c);
        rd_timer_mark(&c, &timer, "tlas");
        res = rd_cmd_submit_wait(vk, &c, err, errlen);
    }
    if (res == RD_VK_OK) res = rd_timer_resolve(vk, &timer, err, errlen);
    if (res == RD_VK_OK && timer.valid) {
        d->blas_build_ms = timer.ms[1];
        d->tlas_build_ms = timer.ms[2];
    }
    rd_timer_destroy(vk, &timer);
    d->tlas_address = as_address(d, d->tlas);
    rd_buffer_destroy(vk, &d->scratch); /* builds are done */
done:
    free(geo);
    free(info);
    free(range);
    free(ranges);
    free(as_off);
    free(scr_off);
    free(src);
    return res;
}

static rd_vk_result create_pipeline(rtb_driver *d, char *err, size_t errlen)
{
    rd_vk *vk = d->vk;
    const uint32_t *code[3] = {pc_spv_rtb_rgen, pc_spv_rtb_rmiss, pc_spv_rtb_rchit};
    const size_t bytes[3] = {sizeof pc_spv_rtb_rgen, sizeof pc_spv_rtb_rmiss,
                             sizeof pc_spv_rtb_rchit};
    const VkShaderStageFlagBits stage[3] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR,
                                            VK_SHADER_STAGE_MISS_BIT_KHR,
                                            VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR};
    VkPipelineShaderStageCreateInfo stages[3];
    for (int i = 0; i < 3; i++) {
        VkShaderModuleCreateInfo mci = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                        .codeSize = bytes[i],
                                        .pCode = code[i]};
        VkResult r = vkCreateShaderModule(vk->device, &mci, NULL, &d->modules[i]);
        if (r != VK_SUCCESS) {
            d->modules[i] = VK_NULL_HANDLE;
            return rd_vk_fail(vk, r, "vkCreateShaderModule (ray tracing)", err, errlen);
        }
        stages[i] = (VkPipelineShaderStageCreateInfo){
            .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
            .stage = stage[i],
            .module = d->modules[i],
            .pName = "main"};
    }
    VkPushConstantRange pcr = {.stageFlags = VK_SHADER_STAGE_RAYGEN_BIT_KHR,
                               .size = sizeof(pc_push)};
    VkPipelineLayoutCreateInfo plci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                       .pushConstantRangeCount = 1,
                                       .pPushConstantRanges = &pcr};
    VkResult r = vkCreatePipelineLayout(vk->device, &plci, NULL, &d->layout);
    if (r != VK_SUCCESS) {
        d->layout = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreatePipelineLayout (ray tracing)", err, errlen);
    }
    VkRayTracingShaderGroupCreateInfoKHR groups[3];
    for (uint32_t i = 0; i < 3; i++)
        groups[i] = (VkRayTracingShaderGroupCreateInfoKHR){
            .sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR,
            .type = i == 2 ? VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR
                           : VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR,
            .generalShader = i == 2 ? VK_SHADER_UNUSED_KHR : i,
            .closestHitShader = i == 2 ? 2 : VK_SHADER_UNUSED_KHR,
            .anyHitShader = VK_SHADER_UNUSED_KHR,
            .intersectionShader = VK_SHADER_UNUSED_KHR};
    VkRayTracingPipelineCreateInfoKHR pci = {
        .sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR,
        .stageCount = 3,
        .pStages = stages,
        .groupCount = 3,
        .pGroups = groups,
        .maxPipelineRayRecursionDepth = 1,
        .layout = d->layout};
    r = fn.create_pipelines(vk->device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &pci, NULL,
                            &d->pipeline);
    if (r != VK_SUCCESS) {
        d->pipeline = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreateRayTracingPipelinesKHR", err, errlen);
    }

    /* shader binding table: raygen, miss, hit; each region on a base-aligned boundary */
    VkPhysicalDeviceRayTracingPipelinePropertiesKHR rtp = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR};
    VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                      .pNext = &rtp};
    vkGetPhysicalDeviceProperties2(vk->physical, &p2);
    uint32_t hsize = rtp.shaderGroupHandleSize;
    VkDeviceSize stride = align_up(hsize, rtp.shaderGroupHandleAlignment);
    VkDeviceSize base = rtp.shaderGroupBaseAlignment ? rtp.shaderGroupBaseAlignment : 64;
    VkDeviceSize region = align_up(stride, base);
    uint8_t handles[3 * 64];
    if (hsize > 64) {
        snprintf(err, errlen, "shader group handles of %u bytes", hsize);
        return RD_VK_ERR_UNSUPPORTED;
    }
    r = fn.group_handles(vk->device, d->pipeline, 0, 3, 3 * hsize, handles);
    if (r != VK_SUCCESS)
        return rd_vk_fail(vk, r, "vkGetRayTracingShaderGroupHandlesKHR", err, errlen);
    rd_vk_result res =
        rd_buffer_create_usage(vk, &d->sbt, 3 * region + base, RD_MEMORY_UPLOAD,
                               VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR, err, errlen);
    if (res != RD_VK_OK) return res;
    VkDeviceAddress start = align_up(d->sbt.address, base);
    for (int i = 0; i < 3; i++)
        memcpy((uint8_t *)d->sbt.mapped + (start - d->sbt.address) + i * region,
               handles + i * hsize, hsize);
    d->rgen = (VkStridedDeviceAddressRegionKHR){start, stride, stride};
    d->miss = (VkStridedDeviceAddressRegionKHR){start + region, stride, stride};
    d->hit = (VkStridedDeviceAddressRegionKHR){start + 2 * region, stride, stride};
    d->callable = (VkStridedDeviceAddressRegionKHR){0, 0, 0};
    const VkPhysicalDeviceLimits *lim = &vk->properties.limits;
    uint64_t max_w = (uint64_t)lim->maxComputeWorkGroupCount[0] * lim->maxComputeWorkGroupSize[0];
    if (rtp.maxRayDispatchInvocationCount < max_w) max_w = rtp.maxRayDispatchInvocationCount;
    if (d->launch_width == 0 || d->launch_width > max_w)
        d->launch_width = max_w > UINT32_MAX ? UINT32_MAX : (uint32_t)max_w;
    return RD_VK_OK;
}

rd_vk_result rtb_driver_create(rd_vk *vk, rtb_driver *d, const rd_scene *scene,
                               const rd_gpu_scene *gs, uint32_t launch_width, char *err,
                               size_t errlen)
{
    memset(d, 0, sizeof *d);
    d->vk = vk;
    d->launch_width = launch_width;
    if (!load_functions(vk->device)) {
        snprintf(err, errlen, "the device returned no VK_KHR ray tracing entry points");
        return RD_VK_ERR_UNSUPPORTED;
    }
    rd_vk_result res = build_structures(d, scene, gs, err, errlen);
    if (res == RD_VK_OK) res = create_pipeline(d, err, errlen);
    if (res != RD_VK_OK) rtb_driver_destroy(d);
    return res;
}

void rtb_driver_record_trace(rtb_driver *d, rd_cmd *c, VkDeviceAddress rays, VkDeviceAddress hits,
                             uint32_t count)
{
    pc_push push = {
        .buf0 = rays, .buf1 = hits, .buf2 = d->tlas_address, .params = {count, 0, 0, 0}};
    vkCmdBindPipeline(c->cb, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, d->pipeline);
    vkCmdPushConstants(c->cb, d->layout, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0, sizeof push, &push);
    /* one row, so that a warp takes consecutive rays as ours does, unless the width limit
     * (launch_width) asks for more rows */
    uint32_t w = count < d->launch_width ? count : d->launch_width;
    uint32_t h = w ? (count + w - 1) / w : 0;
    if (w) fn.trace_rays(c->cb, &d->rgen, &d->miss, &d->hit, &d->callable, w, h, 1);
}

void rtb_driver_destroy(rtb_driver *d)
{
    rd_vk *vk = d->vk;
    if (!vk) return;
    rd_vk_wait_idle(vk);
    if (d->pipeline) vkDestroyPipeline(vk->device, d->pipeline, NULL);
    if (d->layout) vkDestroyPipelineLayout(vk->device, d->layout, NULL);
    for (int i = 0; i < 3; i++)
        if (d->modules[i]) vkDestroyShaderModule(vk->device, d->modules[i], NULL);
    if (d->tlas) fn.destroy_as(vk->device, d->tlas, NULL);
    for (uint32_t m = 0; m < d->blas_count; m++)
        if (d->blas[m]) fn.destroy_as(vk->device, d->blas[m], NULL);
    free(d->blas);
    rd_buffer_destroy(vk, &d->sbt);
    rd_buffer_destroy(vk, &d->instances);
    rd_buffer_destroy(vk, &d->scratch);
    rd_buffer_destroy(vk, &d->tlas_mem);
    rd_buffer_destroy(vk, &d->blas_mem);
    rd_buffer_destroy(vk, &d->verts);
    memset(d, 0, sizeof *d);
}
