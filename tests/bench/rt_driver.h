/* rt_driver.h: the driver's own ray tracer (VK_KHR_acceleration_structure and
 * VK_KHR_ray_tracing_pipeline) over the triangles and instances of a renderer scene, the
 * yardstick of tests/bench/rt_yardstick.c. Benchmark code only: the product never enables
 * VK_KHR ray tracing.
 *
 * The BLASes are built from a copy of the renderer's own triangle buffer (rd_gpu_scene.tris:
 * pc_tri records, 16-byte vertex stride, meshes back to back), one BLAS per mesh, and the TLAS
 * from the renderer's instance transforms (floating origin included), so both tracers see
 * bit-identical world geometry. Every geometry is opaque; nothing is culled.
 */
#ifndef RTB_DRIVER_H
#define RTB_DRIVER_H

#include "renderer/accel/gpu_scene.h"
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"

/* Extensions and feature structs to enable at device creation (rd_vk_options extra_*). */
typedef struct rtb_driver_features {
    VkPhysicalDeviceAccelerationStructureFeaturesKHR as;
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt;
} rtb_driver_features;

/* Fills f and the extra_* members of o (o keeps pointing into f: f must outlive creation). */
void rtb_driver_device_options(rtb_driver_features *f, rd_vk_options *o);

typedef struct rtb_driver {
    rd_vk *vk;
    rd_buffer verts; /* copy of the scene's pc_tri array, usable as build input */
    rd_buffer blas_mem, tlas_mem, scratch, instances, sbt;
    VkAccelerationStructureKHR *blas; /* one per mesh */
    uint32_t blas_count;
    VkAccelerationStructureKHR tlas;
    VkDeviceAddress tlas_address;
    VkShaderModule modules[3];
    VkPipelineLayout layout;
    VkPipeline pipeline;
    VkStridedDeviceAddressRegionKHR rgen, miss, hit, callable;
    uint32_t launch_width; /* rays per launch row (the device's limit unless asked for less) */
    double blas_build_ms, tlas_build_ms; /* GPU time of the builds (0 without timestamps) */
    uint64_t as_bytes;                   /* BLASes + TLAS */
} rtb_driver;

/* Builds the BLASes and TLAS of gs (uploaded from scene) and the ray-tracing pipeline. vk must
 * have been created with rtb_driver_device_options. Traces launch rays in rows of launch_width
 * (0: as wide as the device allows, one row: warps then take consecutive rays, as our 1D
 * dispatches do). On failure everything is released. */
rd_vk_result rtb_driver_create(rd_vk *vk, rtb_driver *d, const rd_scene *scene,
                               const rd_gpu_scene *gs, uint32_t launch_width, char *err,
                               size_t errlen);
/* Records a trace of count rays (two vec4 each, as rtb_rays.comp writes them) writing one
 * float hit distance per ray (-1: miss) to hits. */
void rtb_driver_record_trace(rtb_driver *d, rd_cmd *c, VkDeviceAddress rays, VkDeviceAddress hits,
                             uint32_t count);
void rtb_driver_destroy(rtb_driver *d); /* idempotent */

/* A full memory barrier between any two commands (builds, ray tracing, compute, transfers). */
void rtb_barrier_all(rd_cmd *c);

#endif
