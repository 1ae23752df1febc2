/* probecast_jpegbench: one frame's JPEG encoded whole (tjCompress2 on one thread) and in stripes
 * over the daemon's encoder pool (server/encode/encoder_pool.c with server/encode/jpeg_striped.c), at several
 * sizes and thread counts. Prints a table and writes it as CSV. A benchmark, not a test: nothing
 * is asserted.
 *
 * Columns, medians over the runs, the three timings taken in turn in every run (so a machine
 * that gets busier or slower mid-way slows them alike): single_ms: tjCompress2 of the whole
 * frame on this thread; pool_ms: wall time from srv_encoder_submit to the published frame
 * (srv_encoder_wait_frame) with a pool of that many threads, every frame striped (one stripe a
 * thread; a pool of one thread encodes whole, as the daemon does); speedup: single_ms / pool_ms;
 * pool_p10_ms: the pool's 10th percentile (what it reaches when no other work is in the way);
 * stripes_cpu_ms: all stripes one after the other on this thread plus the join (the CPU cost of
 * striping, for every thread count); dispatch_ms: the pool's round trip for a 16-pixel-wide
 * frame in as many stripes (thread wake-ups and bookkeeping, almost no encoding: what pool_ms
 * costs beyond the encode itself); bytes of the single and the striped JPEG. Thread counts above
 * the machine's cores get no pool measurement (those columns are left blank).
 *
 * With --gpu, a second table measures the GPU path (tests/bench/jpeg_gpu.c): colour conversion,
 * 4:2:0, DCT and quantisation in a compute pass, the coefficients copied to host memory, then
 * entropy-coded by libjpeg on the CPU, whole on one thread or striped over n threads and joined.
 * The frame is uploaded once per size, untimed (the renderer's frame already lies on the GPU).
 * Every thread count has two rows: coefs "copy" (the pass writes device memory, then a copy to
 * host memory) and "direct" (the pass writes host-visible memory over the bus, no copy).
 * Columns, medians: dct_ms and copy_ms: GPU timestamps around the pass and the copy;
 * gpu_wall_ms: record, submit and wait on the host; rgba_copy_ms and rgba_wall_ms: the same for
 * copying the RGBA frame to host memory instead, as the renderer does for the CPU encoders (so
 * not in their columns; a cost the GPU path saves); entropy_ms: the CPU coding (and the join);
 * total_ms: gpu_wall_ms + entropy_ms in one span (submit to JPEG), total_p10_ms its 10th
 * percentile; single_ms: tjCompress2 as in the first table, timed in turn with the GPU path;
 * bytes and ratio: against that single encode; psnr_src_db and psnr_ref_db: the GPU path's
 * JPEG decoded (tjDecompress2) against the source and against the single encode's decode;
 * single_psnr_db: the single encode's decode against the source. No
 * Vulkan device: the table says "unsupported" and the program still exits 0.
 *
 *   probecast_jpegbench [--image frame.png|frame.ppm] [--sizes 1280x720,1920x1080]
 *                       [--threads 1,2,4,8,16] [--runs 31] [--quality 80] [--machine NAME]
 *                       [--csv tests/bench/results/jpeg_encode.csv]
 *                       [--gpu] [--device SELECTOR] [--gpu-csv jpeg_gpu.csv]
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>
#include <unistd.h>

#include "bench_frame.h"
#include "jpeg_gpu.h"
#include "server/base/clock.h"
#include "server/encode/encoder_pool.h"
#include "server/encode/jpeg_striped.h"

#define MAX_LIST 16

/* ---- measuring ------------------------------------------------------------------------------- */

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The q-quantile (0..1) of v (sorted in place), by the nearest rank. */
static double quantile(double *v, unsigned n, double q)
{
    qsort(v, n, sizeof *v, cmp_double);
    unsigned i = (unsigned)(q * (n - 1) + 0.5);
    return v[i < n ? i : n - 1];
}

static double median(double *v, unsigned n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* One table row. The three timings are taken in turn within every run, so that a busy or
 * throttled machine slows them alike. */
typedef struct row {
    unsigned stripes;
    double single_ms, pool_ms, cpu_ms; /* medians; pool_ms < 0: not measured */

    double dispatch_ms; /* the pool's round trip for a tiny frame */
    double pool_p10_ms; /* the fastest tenth of the pool's runs end here */
    size_t single_bytes, striped_bytes;
} row;

static double elapsed(double t0)
{
    return srv_mono_ms() - t0;
}

/* Submits img as frame `id` of view `view` and waits for it: milliseconds, and its size. */
static double round_trip(srv_encoder_pool *p, srv_image *img, uint32_t view, uint64_t id,
                         unsigned q, size_t *size)
{
    srv_frame_info info = {.frame_id = id, .view_id = view, .still = true};
    double t0 = srv_mono_ms();
    srv_encoder_submit(p, img, &info, q);
    srv_frame *f = srv_encoder_wait_frame(p, view, id - 1, 10000);
    double ms = elapsed(t0);
    if (!f) {
        fprintf(stderr, "no frame from the pool\n");
        exit(1);
    }
    *size = srv_frame_best(f)->size;
    srv_frame_unref(f);
    return ms;
}

static void measure(const uint8_t *rgba, unsigned w, unsigned h, unsigned q, unsigned threads,
                    unsigned runs, bool with_pool, row *out)
{
    enum { WARMUP = 3 };
    tjhandle tj = tjInitCompress();
    srv_jpeg_plan plan;
    srv_jpeg_plan_make(&plan, w, h, threads, SRV_STRIPE_MIN_MCU_ROWS);
    srv_jpeg_encoder *e = srv_jpeg_encoder_create();
    srv_jpeg_buf *bufs = calloc(plan.stripe_count, sizeof *bufs);
    srv_encoder_pool *p = with_pool ? srv_encoder_pool_create(threads) : NULL;

    srv_image *img = NULL, *tiny = NULL;
    if (p) {
        srv_encoder_set_stripe_min_pixels(p, 1); /* every size striped, as 1 Mpixel would be */

        img = srv_image_new(w, h);
        memcpy(img->data, rgba, (size_t)w * h * 4);
        /* one MCU column, two MCU rows a thread: as many stripes as the frame, almost no work */
        tiny = srv_image_new(16, 32 * threads);
        memset(tiny->data, 128, (size_t)tiny->width * tiny->height * 4);
    }
    double *ts = calloc(runs, sizeof *ts), *tc = calloc(runs, sizeof *tc);
    double *tp = calloc(runs, sizeof *tp), *td = calloc(runs, sizeof *td);

    memset(out, 0, sizeof *out);
    out->stripes = plan.stripe_count;
    for (unsigned r = 0; r < runs + WARMUP; r++) {
        unsigned k = r < WARMUP ? 0 : r - WARMUP;
        unsigned char *jpeg = NULL;
        unsigned long size = 0;
        double t0 = srv_mono_ms();
        if (tjCompress2(tj, rgba, (int)w, 0, (int)h, TJPF_RGBA, &jpeg, &size, TJSAMP_420, (int)q,
                        TJFLAG_FASTDCT) != 0) {
            fprintf(stderr, "tjCompress2: %s\n", tjGetErrorStr2(tj));
            exit(1);
        }
        ts[k] = elapsed(t0);
        out->single_bytes = size;
        tjFree(jpeg);

        t0 = srv_mono_ms();
        for (unsigned i = 0; i < plan.stripe_count; i++)
            srv_jpeg_encode_stripe(e, &plan, rgba, q, i, &bufs[i]);
        size_t cap = srv_jpeg_join_bound(&plan, bufs), joined = 0;
        uint8_t *all = malloc(cap);
        if (srv_jpeg_join(&plan, bufs, all, cap, &joined) != SRV_JPEG_OK) exit(1);
        free(all);
        tc[k] = elapsed(t0);
        out->striped_bytes = joined;

        if (p) {
            size_t size = 0, tiny_size = 0;
            tp[k] = round_trip(p, img, 1, r + 1, q, &size);

            td[k] = round_trip(p, tiny, 2, r + 1, q, &tiny_size);
            if (threads > 1 && size != joined) {
                fprintf(stderr, "the pool's JPEG is not the joined stripes\n");
                exit(1);
            }
        }
    }
    out->single_ms = median(ts, runs);
    out->cpu_ms = median(tc, runs);
    out->pool_ms = p ? median(tp, runs) : -1;
    out->pool_p10_ms = p ? quantile(tp, runs, 0.1) : -1;
    out->dispatch_ms = p ? median(td, runs) : -1;

    if (p) {
        srv_encoder_stats st;
        srv_encoder_get_stats(p, &st);
        if (st.jpegs_striped == 0) out->stripes = 1; /* a pool of one thread encodes whole */
    }
    free(ts);
    free(tc);
    free(tp);
    free(td);

    srv_image_unref(img);
    srv_image_unref(tiny);
    srv_encoder_pool_destroy(p);

    for (unsigned i = 0; i < plan.stripe_count; i++)
        srv_jpeg_buf_free(&bufs[i]);
    free(bufs);
    srv_jpeg_encoder_destroy(e);
    tjDestroy(tj);
}

/* ---- the GPU path ---------------------------------------------------------------------------- */

typedef struct gpu_row {
    unsigned stripes;
    double dct_ms, copy_ms, wall_ms, entropy_ms, total_ms, total_p10_ms, single_ms; /* medians */
    double rgba_copy_ms, rgba_wall_ms; /* the frame's readback instead (what the CPU path needs) */
    size_t bytes, single_bytes;
    double psnr_src, psnr_ref, psnr_single; /* dB */
} gpu_row;

static double psnr(const uint8_t *a, const uint8_t *b, size_t pixels)
{
    double se = 0;
    for (size_t i = 0; i < pixels; i++)
        for (int k = 0; k < 3; k++) {
            double d = (double)a[4 * i + k] - (double)b[4 * i + k];
            se += d * d;
        }
    return se > 0 ? 10 * log10(255.0 * 255.0 * 3.0 * (double)pixels / se) : 99.0;
}

static uint8_t *decode_rgba(const uint8_t *jpeg, size_t size, unsigned w, unsigned h)
{
    tjhandle tj = tjInitDecompress();
    uint8_t *p = malloc((size_t)w * h * 4);
    if (!p) abort();
    if (tjDecompress2(tj, jpeg, (unsigned long)size, p, (int)w, 0, (int)h, TJPF_RGBA, 0) != 0) {
        fprintf(stderr, "tjDecompress2: %s\n", tjGetErrorStr2(tj));
        exit(1);
    }
    tjDestroy(tj);
    return p;
}

/* The GPU path on g's frame (jpeg_gpu_set_frame done) with `threads` entropy threads, each run
 * timed in turn with one tjCompress2 of the same frame. */
static void measure_gpu(jpeg_gpu *g, const uint8_t *rgba, unsigned threads, unsigned runs,
                        gpu_row *out)
{
    enum { WARMUP = 3 };
    unsigned w = g->width, h = g->height, q = g->quality;
    char err[512] = "";
    tjhandle tj = tjInitCompress();
    srv_jpeg_plan plan;
    srv_jpeg_plan_make(&plan, w, h, threads, SRV_STRIPE_MIN_MCU_ROWS);
    srv_jpeg_buf *bufs = calloc(plan.stripe_count, sizeof *bufs), jpeg = {0};
    double *v[8];
    for (int i = 0; i < 8; i++)
        v[i] = calloc(runs, sizeof(double));
    unsigned char *ref = NULL;
    unsigned long ref_size = 0;
    memset(out, 0, sizeof *out);
    out->stripes = threads > 1 ? plan.stripe_count : 1;
    for (unsigned r = 0; r < runs + WARMUP; r++) {
        unsigned k = r < WARMUP ? 0 : r - WARMUP;
        tjFree(ref);
        ref = NULL;
        double t0 = srv_mono_ms();
        if (tjCompress2(tj, rgba, (int)w, 0, (int)h, TJPF_RGBA, &ref, &ref_size, TJSAMP_420, (int)q,
                        TJFLAG_FASTDCT) != 0) {
            fprintf(stderr, "tjCompress2: %s\n", tjGetErrorStr2(tj));
            exit(1);
        }
        v[5][k] = elapsed(t0);

        jpeg_gpu_times gt;
        t0 = srv_mono_ms();
        rd_vk_result vr = jpeg_gpu_transform(g, &gt, err, sizeof err);
        double t1 = srv_mono_ms();
        bool ok = vr == RD_VK_OK && (threads > 1 ? jpeg_gpu_entropy_striped(g, threads, &plan, bufs,
                                                                            &jpeg, err, sizeof err)
                                                 : jpeg_gpu_entropy(g, &jpeg, err, sizeof err));
        double t2 = srv_mono_ms();
        if (!ok) {
            fprintf(stderr, "GPU path: %s\n", err);
            exit(1);
        }
        v[0][k] = gt.dct_ms, v[1][k] = gt.copy_ms, v[2][k] = gt.wall_ms;
        v[3][k] = t2 - t1, v[4][k] = t2 - t0;
        if (jpeg_gpu_time_frame_copy(g, &gt, err, sizeof err) != RD_VK_OK) {
            fprintf(stderr, "GPU path: %s\n", err);
            exit(1);
        }
        v[6][k] = gt.copy_ms, v[7][k] = gt.wall_ms;
    }
    out->dct_ms = median(v[0], runs);
    out->copy_ms = median(v[1], runs);
    out->wall_ms = median(v[2], runs);
    out->entropy_ms = median(v[3], runs);
    out->total_ms = median(v[4], runs);
    out->total_p10_ms = quantile(v[4], runs, 0.1);
    out->single_ms = median(v[5], runs);
    out->rgba_copy_ms = median(v[6], runs);
    out->rgba_wall_ms = median(v[7], runs);
    out->bytes = jpeg.size;
    out->single_bytes = ref_size;

    uint8_t *dec = decode_rgba(jpeg.data, jpeg.size, w, h);
    uint8_t *ref_dec = decode_rgba(ref, ref_size, w, h);
    out->psnr_src = psnr(dec, rgba, (size_t)w * h);
    out->psnr_ref = psnr(dec, ref_dec, (size_t)w * h);
    out->psnr_single = psnr(ref_dec, rgba, (size_t)w * h);
    free(dec);
    free(ref_dec);
    for (int i = 0; i < 8; i++)
        free(v[i]);
    for (unsigned i = 0; i < plan.stripe_count; i++)
        srv_jpeg_buf_free(&bufs[i]);
    free(bufs);
    srv_jpeg_buf_free(&jpeg);
    tjFree(ref);
    tjDestroy(tj);
}

static unsigned parse_list(const char *s, unsigned *out)
{
    unsigned n = 0;
    while (*s && n < MAX_LIST) {
        char *end;
        out[n++] = (unsigned)strtoul(s, &end, 10);
        s = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') break;
    }
    return n;
}

/* How many cores the machine gives at the moment: n threads each encoding the frame `reps`
 * times with tjCompress2, against one thread doing it alone (n for a machine with n idle cores;
 * less on one shared with other work or with SMT siblings as cores). */
typedef struct gauge_arg {
    const uint8_t *rgba;
    unsigned w, h, q, reps;
} gauge_arg;

static void *gauge_thread(void *arg)
{
    const gauge_arg *a = arg;
    tjhandle tj = tjInitCompress();
    for (unsigned i = 0; i < a->reps; i++) {
        unsigned char *out = NULL;
        unsigned long size = 0;
        tjCompress2(tj, a->rgba, (int)a->w, 0, (int)a->h, TJPF_RGBA, &out, &size, TJSAMP_420,
                    (int)a->q, TJFLAG_FASTDCT);
        tjFree(out);
    }
    tjDestroy(tj);
    return NULL;
}

static double parallelism(const uint8_t *rgba, unsigned w, unsigned h, unsigned q, unsigned n)
{
    gauge_arg a = {rgba, w, h, q, 20};
    double t0 = srv_mono_ms();
    gauge_thread(&a);
    double one = elapsed(t0);
    pthread_t th[MAX_LIST * 4];
    if (n > sizeof th / sizeof th[0]) n = sizeof th / sizeof th[0];
    t0 = srv_mono_ms();
    for (unsigned i = 0; i < n; i++)
        pthread_create(&th[i], NULL, gauge_thread, &a);
    for (unsigned i = 0; i < n; i++)
        pthread_join(th[i], NULL);
    return n * one / elapsed(t0);
}

/* The GPU path's table (see the top of the file); "unsupported" without a usable device. */
static void gpu_table(const char *device, const char *csv, const char *machine, const uint8_t *src,
                      unsigned sw, unsigned sh, unsigned sizes[][2], unsigned size_count,
                      const unsigned *threads, unsigned thread_count, unsigned runs,
                      unsigned quality, long cores)
{
    static rd_vk vk; /* the validation messenger keeps its address */
    char err[512] = "";
    jpeg_gpu g;
    rd_vk_result r = rd_vk_create(&vk, &(rd_vk_options){.device = device}, err, sizeof err);
    if (r == RD_VK_OK) {
        r = jpeg_gpu_create(&g, &vk, err, sizeof err);
        if (r != RD_VK_OK) rd_vk_destroy(&vk);
    }
    if (r != RD_VK_OK) {
        printf("# GPU path: unsupported (%s: %s)\n", rd_vk_strerror(r), err);
        return;
    }
    printf("# GPU path on %s%s: DCT and quantisation on the GPU, entropy coding on n CPU "
           "threads\n",
           vk.device_name, vk.timestamp_period_ns > 0 ? "" : " (no timestamps)");
    printf("%-10s %7s %7s %6s %7s %7s %11s %12s %12s %10s %9s %12s %9s %10s %8s %7s %11s %11s "
           "%14s\n",
           "size", "threads", "stripes", "coefs", "dct_ms", "copy_ms", "gpu_wall_ms",
           "rgba_copy_ms", "rgba_wall_ms", "entropy_ms", "total_ms", "total_p10_ms", "single_ms",
           "bytes", "ratio", "speedup", "psnr_src_db", "psnr_ref_db", "single_psnr_db");
    FILE *out = csv ? fopen(csv, "w") : NULL;
    if (csv && !out) fprintf(stderr, "cannot write %s\n", csv);
    if (out)
        fprintf(out, "machine,device,width,height,quality,threads,stripes,coefs,dct_ms,copy_ms,"
                     "gpu_wall_ms,rgba_copy_ms,rgba_wall_ms,entropy_ms,total_ms,total_p10_ms,"
                     "single_ms,bytes,single_bytes,"
                     "ratio,speedup,psnr_src_db,psnr_ref_db,single_psnr_db\n");
    for (unsigned s = 0; s < size_count; s++) {
        unsigned w = sizes[s][0], h = sizes[s][1];
        uint8_t *rgba = src ? bench_resample(src, sw, sh, w, h) : bench_make_frame(w, h);
        if (jpeg_gpu_set_frame(&g, rgba, w, h, quality, err, sizeof err) != RD_VK_OK) {
            fprintf(stderr, "GPU path: %s\n", err);
            exit(1);
        }
        for (unsigned t = 0; t < 2 * thread_count; t++) {
            unsigned n = threads[t / 2];
            g.direct = t % 2; /* the coefficients copied, or written straight to host memory */
            if (n < 1 || (long)n > cores || n > JPEG_GPU_MAX_THREADS) continue;
            gpu_row rw;
            measure_gpu(&g, rgba, n, runs, &rw);
            double ratio = (double)rw.bytes / (double)rw.single_bytes;
            char sz[32];
            snprintf(sz, sizeof sz, "%ux%u", w, h);
            printf("%-10s %7u %7u %6s %7.3f %7.3f %11.3f %12.3f %12.3f %10.3f %9.3f %12.3f %9.3f "
                   "%10zu "
                   "%8.4f %7.2f %11.2f %11.2f %14.2f\n",
                   sz, n, rw.stripes, g.direct ? "direct" : "copy", rw.dct_ms, rw.copy_ms,
                   rw.wall_ms, rw.rgba_copy_ms, rw.rgba_wall_ms, rw.entropy_ms, rw.total_ms,
                   rw.total_p10_ms, rw.single_ms, rw.bytes, ratio, rw.single_ms / rw.total_ms,
                   rw.psnr_src, rw.psnr_ref, rw.psnr_single);
            fflush(stdout);
            if (out)
                fprintf(
                    out,
                    "\"%s\",\"%s\",%u,%u,%u,%u,%u,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,"
                    "%zu,%zu,"
                    "%.4f,%.3f,%.3f,%.3f,%.3f\n",
                    machine, vk.device_name, w, h, quality, n, rw.stripes,
                    g.direct ? "direct" : "copy", rw.dct_ms, rw.copy_ms, rw.wall_ms,
                    rw.rgba_copy_ms, rw.rgba_wall_ms, rw.entropy_ms, rw.total_ms, rw.total_p10_ms,
                    rw.single_ms, rw.bytes, rw.single_bytes, ratio, rw.single_ms / rw.total_ms,
                    rw.psnr_src, rw.psnr_ref, rw.psnr_single);
        }
        /* a frame's lag variants: three qualities in one pass or in three */
        static const unsigned qs[3] = {30, 60, 90};
        double fused[64], apart[64];
        unsigned n = runs < 64 ? runs : 64;
        for (unsigned k = 0; k < n; k++)
            if (jpeg_gpu_time_sets(&g, qs, 3, true, &fused[k], err, sizeof err) != RD_VK_OK ||
                jpeg_gpu_time_sets(&g, qs, 3, false, &apart[k], err, sizeof err) != RD_VK_OK) {
                fprintf(stderr, "GPU path: %s\n", err);
                exit(1);
            }
        printf("# %ux%u, qualities 30, 60, 90: one pass %.3f ms, three passes %.3f ms (GPU, "
               "median)\n",
               w, h, median(fused, n), median(apart, n));
        free(rgba);
    }
    if (out) fclose(out);
    jpeg_gpu_destroy(&g);
    rd_vk_destroy(&vk);
}

int main(int argc, char **argv)
{
    const char *image = NULL, *csv = NULL, *machine = "unnamed machine";
    const char *device = NULL, *gpu_csv = NULL;
    bool gpu = false;
    unsigned sizes[MAX_LIST][2] = {{1280, 720}, {1920, 1080}}, size_count = 2;
    unsigned threads[MAX_LIST] = {1, 2, 4, 8, 16}, thread_count = 5;
    unsigned runs = 31, quality = 80;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--gpu")) {
            gpu = true;
            continue;
        }
        if (!v) {
            fprintf(stderr, "%s needs a value (see the comment at the top of jpeg_encode.c)\n", a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--image")) {
            image = v;
        } else if (!strcmp(a, "--csv")) {
            csv = v;
        } else if (!strcmp(a, "--gpu-csv")) {
            gpu_csv = v;
            gpu = true;
        } else if (!strcmp(a, "--device")) {
            device = v;
        } else if (!strcmp(a, "--machine")) {
            machine = v;
        } else if (!strcmp(a, "--runs")) {
            runs = (unsigned)atoi(v);
        } else if (!strcmp(a, "--quality")) {
            quality = (unsigned)atoi(v);
        } else if (!strcmp(a, "--threads")) {
            thread_count = parse_list(v, threads);
        } else if (!strcmp(a, "--sizes")) {
            size_count = 0;
            for (const char *s = v; *s && size_count < MAX_LIST;) {
                unsigned w, h;
                int used = 0;
                if (sscanf(s, "%ux%u%n", &w, &h, &used) != 2) break;
                sizes[size_count][0] = w, sizes[size_count++][1] = h;
                s += used;
                if (*s == ',') s++;
            }
        } else {
            fprintf(stderr, "unknown option %s\n", a);
            return 2;
        }
    }
    if (runs < 1 || quality < 1 || quality > 100 || !size_count || !thread_count) return 2;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    uint8_t *src = NULL;
    unsigned sw = 0, sh = 0;
    if (image && !(src = bench_read_image(image, &sw, &sh))) {
        fprintf(stderr, "cannot read %s (PNG or binary PPM)\n", image);
        return 1;
    }

    FILE *out = csv ? fopen(csv, "w") : NULL;
    if (csv && !out) {
        fprintf(stderr, "cannot write %s\n", csv);
        return 1;
    }
    printf("# JPEG encode, 4:2:0 q%u fast DCT, %s (%ld cores), image %s, median of %u runs\n",
           quality, machine, cores, image ? image : "generated", runs);
    {
        uint8_t *g = bench_make_frame(640, 360);
        printf("# cores available now (tjCompress2 on n threads at once against one, before the "
               "table): %.2f of %ld\n",
               parallelism(g, 640, 360, quality, (unsigned)cores), cores);
        free(g);
    }
    printf("%-10s %7s %7s %10s %9s %8s %11s %14s %11s %12s %13s %7s\n", "size", "threads",
           "stripes", "single_ms", "pool_ms", "speedup", "pool_p10_ms", "stripes_cpu_ms",
           "dispatch_ms", "single_bytes", "striped_bytes", "ratio");
    if (out)
        fprintf(out, "machine,width,height,quality,threads,stripes,single_ms,pool_ms,speedup,"
                     "pool_p10_ms,stripes_cpu_ms,dispatch_ms,single_bytes,striped_bytes,ratio\n");
    for (unsigned s = 0; s < size_count; s++) {
        unsigned w = sizes[s][0], h = sizes[s][1];
        uint8_t *rgba = src ? bench_resample(src, sw, sh, w, h) : bench_make_frame(w, h);
        for (unsigned t = 0; t < thread_count; t++) {
            unsigned n = threads[t];
            if (n < 1) continue;
            row rw;
            measure(rgba, w, h, quality, n, runs, (long)n <= cores, &rw);
            char sz[32], wall_s[32] = "", speed_s[32] = "", disp_s[32] = "", p10_s[32] = "";
            snprintf(sz, sizeof sz, "%ux%u", w, h);
            if (rw.pool_ms >= 0) {
                snprintf(wall_s, sizeof wall_s, "%.3f", rw.pool_ms);
                snprintf(speed_s, sizeof speed_s, "%.2f", rw.single_ms / rw.pool_ms);
                snprintf(disp_s, sizeof disp_s, "%.3f", rw.dispatch_ms);
                snprintf(p10_s, sizeof p10_s, "%.3f", rw.pool_p10_ms);
            }
            size_t striped = rw.stripes > 1 ? rw.striped_bytes : rw.single_bytes;
            double ratio = (double)striped / (double)rw.single_bytes;
            printf("%-10s %7u %7u %10.3f %9s %8s %11s %14.3f %11s %12zu %13zu %7.4f\n", sz, n,
                   rw.stripes, rw.single_ms, wall_s[0] ? wall_s : "-", speed_s[0] ? speed_s : "-",
                   p10_s[0] ? p10_s : "-", rw.cpu_ms, disp_s[0] ? disp_s : "-", rw.single_bytes,
                   striped, ratio);
            fflush(stdout);
            if (out)
                fprintf(out, "\"%s\",%u,%u,%u,%u,%u,%.3f,%s,%s,%s,%.3f,%s,%zu,%zu,%.4f\n", machine,
                        w, h, quality, n, rw.stripes, rw.single_ms, wall_s, speed_s, p10_s,
                        rw.cpu_ms, disp_s, rw.single_bytes, striped, ratio);
        }
        free(rgba);
    }
    if (out) fclose(out);
    if (gpu)
        gpu_table(device, gpu_csv, machine, src, sw, sh, sizes, size_count, threads, thread_count,
                  runs, quality, cores);
    {
        uint8_t *g = bench_make_frame(640, 360);
        printf("# cores available now (after the tables): %.2f of %ld\n",
               parallelism(g, 640, 360, quality, (unsigned)cores), cores);
        free(g);
    }
    free(src);
    return 0;
}
