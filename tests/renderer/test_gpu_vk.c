/* test_gpu_vk.c: device creation, buffers, compute pipelines (kept and shared), timers and the
 * validation counter.
 * Runs with PROBECAST_VALIDATION=1 PROBECAST_DEVICE=llvmpipe under ctest. */
#include "renderer/vk/vk_buffer.h"
#include "renderer/vk/vk_compute.h"
#include "renderer/vk/vk_context.h"
#include "renderer/vk/vk_staging.h"
#include "shaders/gpu_types.h"
#include "shaders/test_vk_fill.spv.h"
#include "test_util.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

static char err[512];

/* Host <-> device-local round trip larger than one 64 MiB staging chunk, at an offset too. */
static void test_buffers(rd_vk *vk)
{
    const size_t size = (size_t)70 << 20;
    uint8_t *src = malloc(size), *dst = malloc(size);
    CHECK(src && dst);
    uint32_t state = 12345u;
    for (size_t i = 0; i < size; i++) {
        state = state * 1664525u + 1013904223u;
        src[i] = (uint8_t)(state >> 24);
    }
    rd_buffer b;
    rd_vk_result rc = rd_buffer_create(vk, &b, size, RD_MEMORY_DEVICE, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(b.address != 0 && b.mapped == NULL && b.size == size);
    rc = rd_buffer_upload(vk, &b, 0, src, size, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    memset(dst, 0, size);
    rc = rd_buffer_download(vk, &b, 0, dst, size, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(memcmp(src, dst, size) == 0);

    /* Partial upload straddling the chunk boundary, then a partial download. */
    const size_t off = ((size_t)64 << 20) - 1000, n = 5000;
    memset(src, 0xab, n);
    rc = rd_buffer_upload(vk, &b, off, src, n, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    memset(dst, 0, n + 2);
    rc = rd_buffer_download(vk, &b, off - 1, dst, n + 2, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    int partial_ok = 1;
    for (size_t i = 0; i < n; i++)
        if (dst[1 + i] != 0xab) partial_ok = 0;
    CHECK(partial_ok);

    /* Bounds checks and size 0. */
    err[0] = '\0';
    rc = rd_buffer_upload(vk, &b, size - 4, src, 8, err, sizeof err);
    CHECK(rc == RD_VK_ERR_VULKAN && err[0] != '\0');
    rc = rd_buffer_download(vk, &b, (VkDeviceSize)-1, dst, 2, err, sizeof err);
    CHECK(rc == RD_VK_ERR_VULKAN);
    CHECK(rd_buffer_upload(vk, &b, size, src, 0, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &b, 0, dst, 0, err, sizeof err) == RD_VK_OK);
    rd_buffer_destroy(vk, &b);
    rd_buffer_destroy(vk, &b); /* idempotent */
    CHECK(b.buffer == VK_NULL_HANDLE && b.memory == VK_NULL_HANDLE);

    /* Size 0 rounds up and still has an address. */
    rd_buffer z;
    rc = rd_buffer_create(vk, &z, 0, RD_MEMORY_DEVICE, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(z.size == 16 && z.address != 0);
    CHECK(rd_buffer_fill(vk, &z, 7u, err, sizeof err) == RD_VK_OK);
    rd_buffer_destroy(vk, &z);

    /* Fill, device-local and host-visible. */
    rd_memory kinds[3] = {RD_MEMORY_DEVICE, RD_MEMORY_UPLOAD, RD_MEMORY_READBACK};
    for (int k = 0; k < 3; k++) {
        rd_buffer f;
        rc = rd_buffer_create(vk, &f, 4096, kinds[k], err, sizeof err);
        CHECKF(rc == RD_VK_OK, "%s", err);
        CHECK((kinds[k] == RD_MEMORY_DEVICE) == (f.mapped == NULL));
        rc = rd_buffer_fill(vk, &f, 0xdeadbeefu, err, sizeof err);
        CHECKF(rc == RD_VK_OK, "%s", err);
        uint32_t words[1024];
        rc = rd_buffer_download(vk, &f, 0, words, sizeof words, err, sizeof err);
        CHECKF(rc == RD_VK_OK, "%s", err);
        int fill_ok = 1;
        for (int i = 0; i < 1024; i++)
            if (words[i] != 0xdeadbeefu) fill_ok = 0;
        CHECKF(fill_ok, "fill of memory kind %d", k);
        rd_buffer_destroy(vk, &f);
    }
    free(src);
    free(dst);
}

/* Staging (vk_staging.h): contents staged on another thread, copied by this one. */
typedef struct stage_job {
    rd_vk *vk;
    rd_buffer *dst;
    rd_staging st;
    const uint8_t *src;
    rd_vk_result rc;
} stage_job;

static void *stage_thread(void *arg)
{
    stage_job *j = arg;
    char e[256];
    /* three pieces from memory, one filled in place, one adopted, out of order */
    j->rc = rd_staging_add(j->vk, &j->st, j->dst, 3000, j->src + 3000, 5000, NULL, e, sizeof e);
    if (j->rc == RD_VK_OK) j->rc = rd_upload(j->vk, &j->st, j->dst, 0, j->src, 1000, e, sizeof e);
    void *mapped = NULL;
    if (j->rc == RD_VK_OK)
        j->rc = rd_staging_add(j->vk, &j->st, j->dst, 1000, NULL, 1000, &mapped, e, sizeof e);
    if (j->rc == RD_VK_OK) memcpy(mapped, j->src + 1000, 1000);
    rd_buffer own;
    if (j->rc == RD_VK_OK)
        j->rc = rd_buffer_create(j->vk, &own, 1000, RD_MEMORY_UPLOAD, e, sizeof e);
    if (j->rc == RD_VK_OK) {
        memcpy(own.mapped, j->src + 2000, 1000);
        j->rc = rd_staging_adopt(&j->st, &own, j->dst, 2000, e, sizeof e);
        if (own.buffer) j->rc = RD_VK_ERR_VULKAN; /* adopted: taken */
    }
    if (j->rc == RD_VK_OK)
        j->rc = rd_staging_add(j->vk, &j->st, j->dst, 8000, NULL, 0, &mapped, e, sizeof e);
    if (j->rc == RD_VK_OK && mapped) j->rc = RD_VK_ERR_VULKAN; /* size 0 stages nothing */
    return NULL;
}

static void test_staging(rd_vk *vk)
{
    enum { SIZE = 8192 };
    uint8_t src[SIZE], dst[SIZE];
    for (int i = 0; i < SIZE; i++)
        src[i] = (uint8_t)(i * 7 + 3);
    rd_buffer b;
    CHECK(rd_buffer_create(vk, &b, SIZE, RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_fill(vk, &b, 0, err, sizeof err) == RD_VK_OK);
    stage_job j = {.vk = vk, .dst = &b, .src = src};
    pthread_t t;
    CHECK(pthread_create(&t, NULL, stage_thread, &j) == 0);
    pthread_join(t, NULL);
    CHECKF(j.rc == RD_VK_OK, "staging on another thread: %d", j.rc);
    CHECK(j.st.count == 4 && j.st.bytes == 8000);
    /* nothing reaches the buffer before the copies are recorded and run */
    CHECK(rd_buffer_download(vk, &b, 0, dst, SIZE, err, sizeof err) == RD_VK_OK);
    int untouched = 1;
    for (int i = 0; i < SIZE; i++)
        untouched &= dst[i] == 0;
    CHECK(untouched);
    rd_cmd cmd;
    CHECK(rd_cmd_begin(vk, &cmd, err, sizeof err) == RD_VK_OK);
    rd_staging_record(&j.st, &cmd);
    CHECK(rd_cmd_submit_wait(vk, &cmd, err, sizeof err) == RD_VK_OK);
    rd_staging_release(vk, &j.st);
    rd_staging_release(vk, &j.st); /* idempotent */
    CHECK(j.st.count == 0 && j.st.copies == NULL);
    CHECK(rd_buffer_download(vk, &b, 0, dst, SIZE, err, sizeof err) == RD_VK_OK);
    CHECK(memcmp(dst, src, 8000) == 0);
    int tail_zero = 1;
    for (int i = 8000; i < SIZE; i++)
        tail_zero &= dst[i] == 0;
    CHECK(tail_zero);

    /* out of range: refused with a sentence, nothing staged; release without recording */
    rd_staging s = {0};
    err[0] = '\0';
    CHECK(rd_staging_add(vk, &s, &b, SIZE - 4, src, 8, NULL, err, sizeof err) == RD_VK_ERR_VULKAN);
    CHECK(err[0] != '\0' && s.count == 0);
    CHECK(rd_staging_add(vk, &s, &b, 0, src, 16, NULL, err, sizeof err) == RD_VK_OK);
    rd_staging_release(vk, &s);
    /* rd_upload without staging writes at once; rd_staging_submit_wait runs and releases */
    CHECK(rd_upload(vk, NULL, &b, 0, src + 100, 100, err, sizeof err) == RD_VK_OK);
    CHECK(rd_upload(vk, &s, &b, 100, src, 100, err, sizeof err) == RD_VK_OK);
    CHECK(rd_staging_submit_wait(vk, &s, err, sizeof err) == RD_VK_OK && s.count == 0);
    CHECK(rd_buffer_download(vk, &b, 0, dst, 200, err, sizeof err) == RD_VK_OK);
    CHECK(memcmp(dst, src + 100, 100) == 0 && memcmp(dst + 100, src, 100) == 0);
    rd_buffer_destroy(vk, &b);
}

/* y[i] = a * x[i] + i from a device-local x into a readback y, with a timer around it. */
static void test_compute(rd_vk *vk)
{
    const uint32_t n = 100003, a = 3;
    uint32_t *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    CHECK(x && y);
    for (uint32_t i = 0; i < n; i++)
        x[i] = i * 2654435761u;

    rd_pipeline p;
    rd_vk_result rc =
        rd_pipeline_create(vk, &p, "test_vk_fill", pc_spv_test_vk_fill, sizeof pc_spv_test_vk_fill,
                           sizeof(pc_push), err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    rd_buffer bx, by;
    rc = rd_buffer_create(vk, &bx, n * sizeof *x, RD_MEMORY_DEVICE, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    rc = rd_buffer_create(vk, &by, n * sizeof *y, RD_MEMORY_READBACK, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(rd_buffer_upload(vk, &bx, 0, x, n * sizeof *x, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_fill(vk, &by, 0u, err, sizeof err) == RD_VK_OK);

    rd_timer t;
    rc = rd_timer_create(vk, &t, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    rd_cmd c;
    rc = rd_cmd_begin(vk, &c, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    pc_push push = {.buf0 = bx.address, .buf1 = by.address, .params = {n, a, 0, 0}};
    rd_timer_begin(&c, &t);
    rd_cmd_dispatch(&c, &p, &push, (n + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_timer_mark(&c, &t, "fill");
    rd_cmd_barrier(&c);
    rc = rd_cmd_submit_wait(vk, &c, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(c.cb == VK_NULL_HANDLE && c.fence == VK_NULL_HANDLE);

    rc = rd_buffer_download(vk, &by, 0, y, n * sizeof *y, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    uint32_t bad = 0, first_bad = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (y[i] != a * x[i] + i) {
            if (!bad) first_bad = i;
            bad++;
        }
    }
    CHECKF(bad == 0, "%u wrong values, first at %u: %u != %u", bad, first_bad, y[first_bad],
           a * x[first_bad] + first_bad);

    rc = rd_timer_resolve(vk, &t, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(t.valid == (vk->timestamp_period_ns > 0));
    if (t.valid) {
        CHECK(t.count == 2);
        CHECK(t.names[1] && strcmp(t.names[1], "fill") == 0);
        CHECK(t.ms[0] == 0.0);
        CHECKF(isfinite(t.ms[1]) && t.ms[1] >= 0.0, "ms = %g", t.ms[1]);
        fprintf(stderr, "dispatch of %u invocations: %.3f ms\n", n, t.ms[1]);
    }
    rd_timer_destroy(vk, &t);
    rd_timer_destroy(vk, &t);

    /* Bad pipeline arguments are errors, not crashes. */
    rd_pipeline bad_p;
    rc = rd_pipeline_create(vk, &bad_p, "odd", pc_spv_test_vk_fill, 6, 0, err, sizeof err);
    CHECK(rc != RD_VK_OK && bad_p.pipeline == VK_NULL_HANDLE);
    rc = rd_pipeline_create(vk, &bad_p, "big push", pc_spv_test_vk_fill, sizeof pc_spv_test_vk_fill,
                            4096, err, sizeof err);
    CHECK(rc != RD_VK_OK && bad_p.layout == VK_NULL_HANDLE);

    rd_buffer_destroy(vk, &bx);
    rd_buffer_destroy(vk, &by);
    rd_pipeline_destroy(vk, &p);
    rd_pipeline_destroy(vk, &p);
    CHECK(p.pipeline == VK_NULL_HANDLE);
    free(x);
    free(y);
}

/* Pipelines are kept and shared (vk_compute.c): the same SPIR-V and push size give the same
 * pipeline, whether its first holder still holds it or let go; another push size or SPIR-V gives
 * another; the kept pipeline still runs after its holders let go; rd_vk_destroy destroys them
 * (the validation layer would report one left at vkDestroyDevice). */
static void test_shared_pipelines(rd_vk *vk)
{
    rd_pipeline a, b, c, d;
    size_t bytes = sizeof pc_spv_test_vk_fill;
    CHECK(rd_pipeline_create(vk, &a, "a", pc_spv_test_vk_fill, bytes, sizeof(pc_push), err,
                             sizeof err) == RD_VK_OK);
    size_t kept = vk->pipeline_count;
    /* a copy of the SPIR-V elsewhere in memory: the same pipeline */
    uint32_t *copy = malloc(bytes);
    CHECK(copy != NULL);
    memcpy(copy, pc_spv_test_vk_fill, bytes);
    CHECK(rd_pipeline_create(vk, &b, "b", copy, bytes, sizeof(pc_push), err, sizeof err) ==
          RD_VK_OK);
    CHECK(b.pipeline == a.pipeline && b.layout == a.layout && vk->pipeline_count == kept);
    /* another push size: another layout and pipeline */
    CHECK(rd_pipeline_create(vk, &c, "c", pc_spv_test_vk_fill, bytes, sizeof(pc_push) + 16, err,
                             sizeof err) == RD_VK_OK);
    CHECK(c.pipeline != a.pipeline && c.layout != a.layout && vk->pipeline_count == kept + 1);
    VkPipeline first = a.pipeline;
    rd_pipeline_destroy(vk, &a);
    rd_pipeline_destroy(vk, &b);
    CHECK(a.pipeline == VK_NULL_HANDLE && b.pipeline == VK_NULL_HANDLE);
    CHECK(vk->pipeline_count == kept + 1); /* kept though no one holds it */
    /* let go by both: kept, and handed out again */
    CHECK(rd_pipeline_create(vk, &d, "d", copy, bytes, sizeof(pc_push), err, sizeof err) ==
          RD_VK_OK);
    CHECK(d.pipeline == first && vk->pipeline_count == kept + 1);
    /* and it still runs */
    rd_buffer bx, by;
    CHECK(rd_buffer_create(vk, &bx, 64 * 4, RD_MEMORY_DEVICE, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_create(vk, &by, 64 * 4, RD_MEMORY_READBACK, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_fill(vk, &bx, 5u, err, sizeof err) == RD_VK_OK);
    rd_cmd cmd;
    CHECK(rd_cmd_begin(vk, &cmd, err, sizeof err) == RD_VK_OK);
    pc_push push = {.buf0 = bx.address, .buf1 = by.address, .params = {64, 2, 0, 0}};
    rd_cmd_dispatch(&cmd, &d, &push, 1, 1, 1);
    rd_cmd_barrier(&cmd);
    CHECK(rd_cmd_submit_wait(vk, &cmd, err, sizeof err) == RD_VK_OK);
    uint32_t y[64];
    CHECK(rd_buffer_download(vk, &by, 0, y, sizeof y, err, sizeof err) == RD_VK_OK);
    CHECK(y[0] == 10u && y[63] == 2u * 5u + 63u);
    rd_buffer_destroy(vk, &bx);
    rd_buffer_destroy(vk, &by);
    rd_pipeline_destroy(vk, &c);
    rd_pipeline_destroy(vk, &d);
    free(copy);
}

static void test_selectors(void)
{
    rd_vk v;
    err[0] = '\0';
    rd_vk_result rc =
        rd_vk_create(&v, &(rd_vk_options){.device = "no-such-device"}, err, sizeof err);
    CHECK(rc == RD_VK_ERR_DEVICE_NOT_FOUND);
    CHECK(err[0] != '\0');
    CHECK(v.instance == VK_NULL_HANDLE && v.device == VK_NULL_HANDLE);
    fprintf(stderr, "expected error: %s\n", err);

    rc = rd_vk_create(&v, &(rd_vk_options){.device = "99"}, err, sizeof err);
    CHECK(rc == RD_VK_ERR_DEVICE_NOT_FOUND);

    rc = rd_vk_create(&v, &(rd_vk_options){.device = "0"}, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(v.device != VK_NULL_HANDLE && v.device_name[0] != '\0');
    CHECK(rd_vk_validation_messages(&v) == 0);
    rd_vk_destroy(&v);

    /* Case-insensitive name substring. */
    rc = rd_vk_create(&v, &(rd_vk_options){.device = "LLVMPIPE"}, err, sizeof err);
    if (getenv("PROBECAST_DEVICE") && strcmp(getenv("PROBECAST_DEVICE"), "llvmpipe") == 0)
        CHECKF(rc == RD_VK_OK && v.is_cpu, "%s", err);
    rd_vk_destroy(&v);

    char list[2048];
    rc = rd_vk_list_devices(list, sizeof list, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(strncmp(list, "0: ", 3) == 0);
    fprintf(stderr, "devices:\n%s", list);

    CHECK(strcmp(rd_vk_result_name(VK_ERROR_DEVICE_LOST), "VK_ERROR_DEVICE_LOST") == 0);
    CHECK(rd_vk_from_vkresult(VK_ERROR_DEVICE_LOST) == RD_VK_ERR_DEVICE_LOST);
    CHECK(rd_vk_from_vkresult(VK_SUCCESS) == RD_VK_OK);
}

/* The messenger really counts: a deliberately invalid call raises the counter. */
static void test_validation_counts(void)
{
    rd_vk v;
    rd_vk_result rc = rd_vk_create(&v, &(rd_vk_options){.validation = 1}, err, sizeof err);
    if (rc == RD_VK_ERR_NO_VALIDATION) {
        fprintf(stderr, "skipping the validation counter test: %s\n", err);
        return;
    }
    CHECKF(rc == RD_VK_OK, "%s", err);
    CHECK(v.validation);
    unsigned before = rd_vk_validation_messages(&v);
    fprintf(stderr, "note: the next validation error (buffer size 0) is deliberate\n");
    VkBufferCreateInfo bci = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = 0, /* invalid: VUID-VkBufferCreateInfo-size-00912 */
        .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkBuffer buf = VK_NULL_HANDLE;
    VkResult r = vkCreateBuffer(v.device, &bci, NULL, &buf);
    if (r == VK_SUCCESS && buf) vkDestroyBuffer(v.device, buf, NULL);
    CHECK(rd_vk_validation_messages(&v) > before);
    fprintf(stderr, "note: end of deliberate validation messages\n");
    rd_vk_destroy(&v);
}

int main(void)
{
    rd_vk vk;
    rd_vk_result rc = rd_vk_create(&vk, NULL, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc != RD_VK_OK) return test_finish();
    rd_vk_log_device(&vk, stderr);
    fprintf(stderr, "device name: %s\n", vk.device_name);
    CHECK(vk.device_name[0] != '\0');
    CHECK(vk.queue != VK_NULL_HANDLE && vk.command_pool != VK_NULL_HANDLE);
    const char *want_validation = getenv("PROBECAST_VALIDATION");
    if (want_validation && strcmp(want_validation, "1") == 0) CHECK(vk.validation);

    test_buffers(&vk);
    test_staging(&vk);
    test_compute(&vk);
    test_shared_pipelines(&vk);
    test_selectors();
    test_validation_counts();

    rd_vk_destroy(&vk);
    rd_vk_destroy(&vk); /* idempotent */
    CHECK(vk.device == VK_NULL_HANDLE && vk.instance == VK_NULL_HANDLE);
    CHECK(rd_vk_validation_messages(&vk) == 0);
    return test_finish();
}
