/* vk_compute.h: compute pipelines from embedded SPIR-V, command recording, GPU timestamps.
 *
 * Every pipeline has no descriptor sets and one push-constant range (pc_push from
 * shaders/gpu_types.h, or a smaller block) visible to the compute stage.
 */
#ifndef RD_VK_COMPUTE_H
#define RD_VK_COMPUTE_H

#include <stddef.h>

#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_context.h"

typedef struct rd_pipeline {
    VkShaderModule module;
    VkPipelineLayout layout;
    VkPipeline pipeline;
    uint32_t push_size;
    const char *name;
} rd_pipeline;

rd_vk_result rd_pipeline_create(rd_vk *vk, rd_pipeline *p, const char *name, const uint32_t *spirv,
                                size_t spirv_bytes, uint32_t push_size, char *err, size_t errlen);
void rd_pipeline_destroy(rd_vk *vk, rd_pipeline *p); /* idempotent */

/* One line of a pipeline table: which rd_pipeline member of the owner struct, its name (in
 * error messages), its SPIR-V and its push-constant size. spirv_masked (optional): the shader's
 * PC_MASKED_LANES variant (shaders/common.glsl), used where rd_vk.masked_lanes. */
typedef struct rd_pipeline_desc {
    size_t offset; /* of the rd_pipeline inside the owner */
    const char *name;
    const uint32_t *spirv;
    size_t spirv_bytes;
    uint32_t push_size;
    const uint32_t *spirv_masked;
    size_t spirv_masked_bytes;
} rd_pipeline_desc;

/* A table line for member `member` of `type`, made from the embedded SPIR-V array `spv`. */
#define RD_PIPELINE_DESC(type, member, name, spv, push_size)                                       \
    {                                                                                              \
        RD_PIPELINE_OFFSET(type, member), (name), (spv), sizeof(spv), (push_size), NULL, 0         \
    }
/* The same for a shader of CMakeLists.txt's PC_MASKED_LANE_SHADERS, with its variant spv_masked. */
#define RD_PIPELINE_DESC_MASKED(type, member, name, spv, push_size)                                \
    {                                                                                              \
        RD_PIPELINE_OFFSET(type, member), (name), (spv), sizeof(spv), (push_size), spv##_masked,   \
            sizeof(spv##_masked)                                                                   \
    }
/* offsetof that compiles only for an rd_pipeline member */
#define RD_PIPELINE_OFFSET(type, member)                                                           \
    _Generic(((type *)0)->member, rd_pipeline : offsetof(type, member))

/* Creates the table's pipelines inside owner in order. On failure err names the pipeline that
 * failed, and those created before it are destroyed again. */
rd_vk_result rd_pipelines_create(rd_vk *vk, void *owner, const rd_pipeline_desc *table,
                                 size_t count, char *err, size_t errlen);
/* Destroys the table's pipelines inside owner in reverse order (idempotent). */
void rd_pipelines_destroy(rd_vk *vk, void *owner, const rd_pipeline_desc *table, size_t count);

/* A one-shot command buffer with its fence. */
typedef struct rd_cmd {
    VkCommandBuffer cb;
    VkFence fence;
} rd_cmd;

rd_vk_result rd_cmd_begin(rd_vk *vk, rd_cmd *c, char *err, size_t errlen);
/* Gives back the command buffer and fence of a finished or never submitted c (they are reused). */
void rd_cmd_release(rd_vk *vk, rd_cmd *c);
/* Ends, submits, waits for completion and frees the command buffer and fence. */
rd_vk_result rd_cmd_submit_wait(rd_vk *vk, rd_cmd *c, char *err, size_t errlen);
/* Frees a begun command buffer that will not be submitted (an error while recording). */
void rd_cmd_abandon(rd_vk *vk, rd_cmd *c);
/* Binds p, pushes push (p->push_size bytes) and dispatches groups. */
void rd_cmd_dispatch(rd_cmd *c, const rd_pipeline *p, const void *push, uint32_t gx, uint32_t gy,
                     uint32_t gz);
/* Same, with the group counts read by the GPU from args at offset (three uint32_t). */
void rd_cmd_dispatch_indirect(rd_cmd *c, const rd_pipeline *p, const void *push,
                              const rd_buffer *args, VkDeviceSize offset);
/* Full compute->compute, compute->indirect-args and transfer->compute memory barrier. */
void rd_cmd_barrier(rd_cmd *c);

#define RD_TIMER_MAX 32

/* GPU timestamps around named passes: mark(start) ... mark(name) ... ; resolve -> ms each. */
typedef struct rd_timer {
    VkQueryPool pool;
    uint32_t count; /* timestamps written this frame */
    const char *names[RD_TIMER_MAX];
    double ms[RD_TIMER_MAX]; /* ms[i]: time between timestamp i-1 and i (ms[0] = 0) */
    bool valid;              /* false when the device has no timestamps */
} rd_timer;

rd_vk_result rd_timer_create(rd_vk *vk, rd_timer *t, char *err, size_t errlen);
void rd_timer_destroy(rd_vk *vk, rd_timer *t);
/* Resets the pool inside c and starts a frame (writes timestamp 0 named "start"). */
void rd_timer_begin(rd_cmd *c, rd_timer *t);
/* Writes a timestamp after all prior work; the section since the previous mark gets name. */
void rd_timer_mark(rd_cmd *c, rd_timer *t, const char *name);
/* After the command buffer completed: fills ms[]. */
rd_vk_result rd_timer_resolve(rd_vk *vk, rd_timer *t, char *err, size_t errlen);

#endif
