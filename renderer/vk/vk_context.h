/* vk_context.h: headless Vulkan instance and device for compute.
 *
 * Device choice: options.device, else $PROBECAST_DEVICE, else the best ranked device
 * (discrete > integrated > virtual > CPU, e.g. lavapipe). A selector is a decimal index into
 * the physical-device list or a case-insensitive substring of the device name.
 * Validation: options.validation, or $PROBECAST_VALIDATION=1, enables VK_LAYER_KHRONOS_validation
 * with a debug messenger; every warning or error message is logged to stderr and counted.
 * Requires Vulkan 1.2 with bufferDeviceAddress, shaderInt64 and storageBuffer16BitAccess.
 */
#ifndef RD_VK_CONTEXT_H
#define RD_VK_CONTEXT_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <vulkan/vulkan.h>

typedef enum rd_vk_result {
    RD_VK_OK = 0,
    RD_VK_ERR_NO_LOADER,        /* no Vulkan loader / instance creation failed */
    RD_VK_ERR_NO_VALIDATION,    /* validation asked for but the layer is missing */
    RD_VK_ERR_NO_DEVICE,        /* no physical device at all */
    RD_VK_ERR_DEVICE_NOT_FOUND, /* the selector matched no device */
    RD_VK_ERR_UNSUPPORTED,      /* device lacks a required feature */
    RD_VK_ERR_OUT_OF_MEMORY,
    RD_VK_ERR_DEVICE_LOST,
    RD_VK_ERR_VULKAN, /* any other VkResult failure (detail in the message) */
} rd_vk_result;

const char *rd_vk_strerror(rd_vk_result r);
const char *rd_vk_result_name(VkResult r); /* "VK_ERROR_DEVICE_LOST" ... */
/* Maps a VkResult to rd_vk_result (VK_SUCCESS -> RD_VK_OK). */
rd_vk_result rd_vk_from_vkresult(VkResult r);

typedef struct rd_vk_options {
    const char *device; /* selector, NULL = $PROBECAST_DEVICE or automatic */
    int validation;     /* 0 = $PROBECAST_VALIDATION, 1 = on, -1 = off */
    /* Extra device extensions and feature structs, for tools that need more than the renderer
     * (tests/bench/rt_driver.c enables VK_KHR ray tracing with them; the product never sets
     * them). A missing extension fails creation with RD_VK_ERR_UNSUPPORTED and names it.
     * extra_features is a pNext chain appended after the renderer's own feature structs
     * (Vulkan 1.1 and 1.2 features: the chain must not repeat those); NULL = none. */
    const char *const *extra_extensions;
    uint32_t extra_extension_count;
    void *extra_features;
} rd_vk_options;

#define RD_VK_SPARE_CMDS 32

/* A compute pipeline that rd_pipeline objects share (vk_compute.c): its key (the SPIR-V's 64-bit
 * FNV-1a hash and size, the push-constant size), its objects and how many rd_pipeline hold it now
 * (it stays when none does, until rd_vk_destroy). */
typedef struct rd_shared_pipeline {
    uint64_t hash;
    size_t spirv_bytes;
    uint32_t push_size;
    unsigned refs;
    VkShaderModule module;
    VkPipelineLayout layout;
    VkPipeline pipeline;
} rd_shared_pipeline;

typedef struct rd_vk {
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    VkPhysicalDevice physical;
    VkDevice device;
    VkQueue queue;
    uint32_t queue_family;
    VkCommandPool command_pool;
    /* finished command buffers and their fences, reused by rd_cmd_begin: allocating both cost
     * 0.42 ms a frame on an H200 (vk_compute.c) */
    VkCommandBuffer spare_cb[RD_VK_SPARE_CMDS];
    VkFence spare_fence[RD_VK_SPARE_CMDS];
    unsigned spare_count;
    VkPhysicalDeviceProperties properties;
    VkPhysicalDeviceMemoryProperties memory;
    double timestamp_period_ns; /* 0 when the queue has no timestamps */
    bool validation;
    bool is_cpu; /* lavapipe or another CPU implementation */
    /* pipelines use their shaders' PC_MASKED_LANES variants (shaders/common.glsl): is_cpu, unless
     * $PROBECAST_MASKED_LANES is 0 or 1 (tests compare both variants' images on one device) */
    bool masked_lanes;
    atomic_uint validation_messages;
    char device_name[VK_MAX_PHYSICAL_DEVICE_NAME_SIZE];
    /* Optional features, enabled when the device has them. */
    bool has_scalar_block_layout;
    bool has_shader_float16;
    bool has_shader_int16;
    uint32_t timestamp_valid_bits; /* of the chosen queue family; 0 = no timestamps */
    bool device_lost;              /* set once any call saw VK_ERROR_DEVICE_LOST */
    /* the compute pipelines made so far, shared by every rd_pipeline of the same SPIR-V and push
     * size (vk_compute.c says why); guarded by pipelines_lock */
    rd_shared_pipeline *pipelines;
    size_t pipeline_count, pipeline_cap;
    pthread_mutex_t pipelines_lock;
} rd_vk;

/* Creates instance, device, queue and command pool. On failure returns a code, writes a
 * sentence to err and leaves vk destroyed (nothing to clean up). opt may be NULL.
 * The debug messenger counts into vk->validation_messages, so vk must not move in memory
 * between rd_vk_create and rd_vk_destroy. */
rd_vk_result rd_vk_create(rd_vk *vk, const rd_vk_options *opt, char *err, size_t errlen);
/* Waits for the device, destroys in reverse order; idempotent. */
void rd_vk_destroy(rd_vk *vk);
/* Waits until the device has finished all submitted work (nothing when it was lost). */
void rd_vk_wait_idle(rd_vk *vk);
/* Number of validation warnings/errors reported so far. */
unsigned rd_vk_validation_messages(rd_vk *vk);
/* Writes one line per physical device ("INDEX: NAME (TYPE)") to out. */
rd_vk_result rd_vk_list_devices(char *out, size_t outlen, char *err, size_t errlen);
/* Writes one line describing the chosen device (name, type, API version, driver) to f. */
void rd_vk_log_device(const rd_vk *vk, FILE *f);

/* Helpers shared by the renderer modules. rd_vk_fail logs "what failed: VK_..." to stderr,
 * writes it as a sentence to err, marks vk->device_lost on VK_ERROR_DEVICE_LOST (vk may be
 * NULL) and returns rd_vk_from_vkresult(r). rd_vk_errorf formats into err (err may be NULL). */
rd_vk_result rd_vk_fail(rd_vk *vk, VkResult r, const char *what, char *err, size_t errlen);
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
void rd_vk_errorf(char *err, size_t errlen, const char *fmt, ...);

#endif
