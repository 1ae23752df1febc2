/* test_gpu_video_i420.c: the GPU's I420 for video viewers (renderer/encode/video_i420.c,
 * shaders/video_i420.comp) is bit exact with the CPU conversion the encoders use otherwise
 * (srv_video_rgba_to_i420), at tiny sizes, odd ones too (a last column or row that averages
 * what it has), and the bytes past the width repeat the last column. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/encode/video_i420.h"
#include "server/encode/video_encoder.h"
#include "test_render_util.h"
#include "test_util.h"

static char err[512];

/* Gradients, a hard edge and per-channel noise: neighbouring chroma differs everywhere. */
static uint8_t *make_image(unsigned w, unsigned h, uint32_t seed)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < w; x++) {
            uint8_t *px = p + ((size_t)y * w + x) * 4;
            int c[3] = {(int)(255 * x / (w > 1 ? w - 1 : 1)), (int)(255 * y / (h > 1 ? h - 1 : 1)),
                        x + 2 * y < w ? 250 : 10};
            for (int k = 0; k < 3; k++) {
                seed = seed * 1664525u + 1013904223u;
                int v = c[k] + (int)((seed >> 24) % 61) - 30;
                px[k] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            px[3] = (uint8_t)(seed >> 8); /* alpha is ignored */
        }
    return p;
}

static bool check_size(rd_vk *vk, const rd_video_i420 *pass, unsigned w, unsigned h)
{
    bool ok = false;
    rd_buffer rgba = {0}, planes = {0};
    rd_cmd cmd = {0};
    uint8_t *img = make_image(w, h, w * 7919u + h);
    rd_i420_layout l = rd_i420_layout_of(w, h);
    uint8_t *gpu = malloc(l.bytes), *cpu = calloc(1, l.bytes);
    VK_CHECK(
        rd_buffer_create(vk, &rgba, (VkDeviceSize)w * h * 4, RD_MEMORY_DEVICE, err, sizeof err));
    VK_CHECK(rd_buffer_create(vk, &planes, l.bytes, RD_MEMORY_DEVICE, err, sizeof err));
    VK_CHECK(rd_buffer_upload(vk, &rgba, 0, img, (VkDeviceSize)w * h * 4, err, sizeof err));
    VK_CHECK(rd_cmd_begin(vk, &cmd, err, sizeof err));
    rd_video_i420_record(pass, &cmd, &rgba, w, h, &planes);
    rd_cmd_barrier(&cmd);
    VK_CHECK(rd_cmd_submit_wait(vk, &cmd, err, sizeof err));
    VK_CHECK(rd_buffer_download(vk, &planes, 0, gpu, l.bytes, err, sizeof err));
    srv_video_rgba_to_i420(img, (size_t)w * 4, w, h, cpu, l.y_stride, cpu + l.cb_at, cpu + l.cr_at,
                           l.c_stride);
    /* within the picture: the same bytes; past it (Y): the last column again */
    unsigned bad = 0, bad_pad = 0, cw = (w + 1) / 2;
    for (unsigned y = 0; y < h; y++)
        for (unsigned x = 0; x < l.y_stride; x++) {
            uint8_t g = gpu[y * l.y_stride + x];
            if (x < w)
                bad += g != cpu[y * l.y_stride + x];
            else
                bad_pad += g != cpu[y * l.y_stride + w - 1];
        }
    for (unsigned y = 0; y < l.c_rows; y++)
        for (unsigned x = 0; x < cw; x++) {
            bad += gpu[l.cb_at + y * l.c_stride + x] != cpu[l.cb_at + y * l.c_stride + x];
            bad += gpu[l.cr_at + y * l.c_stride + x] != cpu[l.cr_at + y * l.c_stride + x];
        }
    CHECKF(bad == 0, "%ux%u: %u bytes differ from the CPU conversion", w, h, bad);
    CHECKF(bad_pad == 0, "%ux%u: %u padding bytes do not repeat the last column", w, h, bad_pad);
    ok = bad == 0 && bad_pad == 0;
done:
    rd_cmd_release(vk, &cmd);
    rd_buffer_destroy(vk, &rgba);
    rd_buffer_destroy(vk, &planes);
    free(img);
    free(gpu);
    free(cpu);
    return ok;
}

int main(void)
{
    rd_vk vk;
    if (!test_vk_open(&vk)) return test_finish();
    rd_video_i420 pass = {0};
    VK_CHECK(rd_video_i420_create(&vk, &pass, err, sizeof err));
    const unsigned sizes[][2] = {{16, 16}, {1, 1}, {17, 9}, {33, 31}, {64, 48}, {100, 3}};
    for (unsigned i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        if (check_size(&vk, &pass, sizes[i][0], sizes[i][1]))
            printf("%ux%u: bit exact\n", sizes[i][0], sizes[i][1]);
done:
    rd_video_i420_destroy(&vk, &pass);
    return test_vk_close(&vk);
}
