/* encoder_pool.c: JPEG encoder threads with latest-frame-wins publication.
 *
 * The stripe threshold, from tests/bench/results/lavapipe/jpeg_encode.txt (2 cores): striping
 * costs little CPU (about 3 us a stripe: the 14 stripes of a 1080p frame take within 1% of one
 * tjCompress2 and add 80 bytes), but every frame pays the wake-up of its threads and of the
 * waiting sender, 0.06-0.2 ms there. With both stripes running at once a 960x540 frame
 * (0.52 Mpixel) took 0.56 instead of 0.96 ms and 640x360 0.31 instead of 0.42 ms; 320x180 lost.
 * Under half a megapixel a frame encodes in under a millisecond on one core anyway, so
 * SRV_STRIPE_MIN_PIXELS is 0.5 Mpixel.
 */
#include "server/encode/encoder_pool.h"
#include "server/base/clock.h"

#include <limits.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <turbojpeg.h>

#include "server/encode/jpeg_coefs.h"
#include "server/encode/jpeg_striped.h"
#include "server/base/log.h"

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n, size);
    if (!p) abort(); /* out of memory */
    return p;
}

/* ---- frames -------------------------------------------------------------------------------- */

/* One variant encoded in stripes (frame-private; its fields change under the pool's lock except
 * bufs[i], which only the job of stripe i writes, and the joiner reads once all are done). */
typedef struct srv_stripe_set {
    srv_jpeg_plan plan;
    srv_jpeg_buf *bufs; /* plan.stripe_count encoded stripes */
    unsigned left;      /* stripe jobs not finished or dropped */
    bool failed;        /* a stripe could not be encoded */
    bool started;
    double start_ms; /* when its first stripe began (for the encode time) */
} srv_stripe_set;

static void stripe_sets_free(srv_frame *f)
{
    if (!f->stripe_sets) return;
    for (unsigned v = 0; v < f->variant_count; v++) {
        srv_stripe_set *s = &f->stripe_sets[v];
        for (unsigned i = 0; s->bufs && i < s->plan.stripe_count; i++)
            srv_jpeg_buf_free(&s->bufs[i]);
        free(s->bufs);
    }
    free(f->stripe_sets);
    f->stripe_sets = NULL;
}

srv_frame *srv_frame_ref(srv_frame *f)
{
    atomic_fetch_add(&f->refs, 1);
    return f;
}

void srv_frame_unref(srv_frame *f)
{
    if (!f || atomic_fetch_sub(&f->refs, 1) != 1) return;
    for (unsigned i = 0; i < f->variant_count; i++)
        free(f->variants[i].data);
    stripe_sets_free(f);
    srv_image_unref(f->image);
    free(f);
}

const srv_jpeg *srv_frame_pick(const srv_frame *f, unsigned quality)
{
    const srv_jpeg *best = &f->variants[0];
    for (unsigned i = 0; i < f->variant_count; i++)
        if (f->variants[i].quality <= quality) best = &f->variants[i];
    return best;
}

const srv_jpeg *srv_frame_best(const srv_frame *f)
{
    return &f->variants[f->variant_count - 1];
}

/* ---- the pool ------------------------------------------------------------------------------- */

typedef struct job {
    srv_frame *frame;
    unsigned variant;
    unsigned stripe; /* when the frame is striped */
    struct job *next;
} job;

struct srv_encoder_pool {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    job *head, *tail;
    bool stop;
    unsigned thread_count;
    pthread_t *threads;
    uint32_t caps;
    unsigned stripe_min_pixels;
    /* the newest published frame of each view (latest frame wins per view) */
    struct {
        uint32_t view_id;
        srv_frame *frame;
    } * latest;
    unsigned latest_count, latest_cap;
    pthread_cond_t published; /* broadcast on every publication (srv_encoder_wait_frame) */
    srv_frame_listener listener;
    void *listener_user;
    srv_encoder_stats stats;
};

/* The slot of view_id in the latest table, or NULL (create: a new empty slot). Lock held. */
static srv_frame **latest_slot(srv_encoder_pool *p, uint32_t view_id, bool create)
{
    for (unsigned i = 0; i < p->latest_count; i++)
        if (p->latest[i].view_id == view_id) return &p->latest[i].frame;
    if (!create) return NULL;
    if (p->latest_count == p->latest_cap) {
        p->latest_cap = p->latest_cap ? 2 * p->latest_cap : 8;
        p->latest = realloc(p->latest, p->latest_cap * sizeof *p->latest);
        if (!p->latest) abort();
    }
    p->latest[p->latest_count].view_id = view_id;
    p->latest[p->latest_count].frame = NULL;
    return &p->latest[p->latest_count++].frame;
}

/* One job of a frame is finished (or dropped); the last one publishes or frees the frame.
 * Called with p->mu held. */
static void job_done(srv_encoder_pool *p, srv_frame *f)
{
    if (--f->remaining > 0) return;
    /* a published frame keeps its RGBA8 pixels for the video encoders (video_stream.h); on the
     * CPU path its view holds the same image anyway (its last image, for stills) */
    bool pixels = !f->image->coef_sets || f->image->i420_y_stride; /* RGBA8 or I420 */
    if (!pixels || f->abandoned) {
        srv_image_unref(f->image);
        f->image = NULL;
    }
    stripe_sets_free(f);
    bool ok = !f->abandoned;
    for (unsigned i = 0; ok && i < f->variant_count; i++)
        ok = f->variants[i].data != NULL;
    srv_frame **slot = ok ? latest_slot(p, f->info.view_id, true) : NULL;
    if (slot && (!*slot || f->info.frame_id > (*slot)->info.frame_id)) {
        f->encode_us = srv_unix_us();
        srv_frame_unref(*slot);
        *slot = f; /* the pool's reference moves to the view's latest */
        p->stats.frames_published++;
        pthread_cond_broadcast(&p->published);
        if (p->listener) p->listener(p->listener_user);
    } else {
        p->stats.frames_dropped++;
        srv_frame_unref(f);
    }
}

/* A job no thread will run (a newer frame replaced its frame, or the pool stops). Lock held. */
static void job_drop(srv_encoder_pool *p, job *j)
{
    srv_frame *f = j->frame;
    f->abandoned = true;
    if (f->stripe_sets) f->stripe_sets[j->variant].left--;
    job_done(p, f);
    free(j);
}

/* Counts one encoded JPEG of ms milliseconds. Lock held. */
static void count_jpeg(srv_encoder_pool *p, size_t size, double ms, bool striped, bool from_gpu)
{
    p->stats.jpegs_encoded++;
    p->stats.jpegs_striped += striped;
    p->stats.jpegs_from_gpu += from_gpu;
    p->stats.bytes_encoded += size;
    p->stats.encode_ms_last = ms;
    p->stats.encode_ms_avg =
        p->stats.jpegs_encoded == 1 ? ms : 0.9 * p->stats.encode_ms_avg + 0.1 * ms;
}

/* Coefficient set `variant` of f's image. */
static srv_jpeg_coefs coefs_of(const srv_frame *f, unsigned variant)
{
    const srv_image *img = f->image;
    return (srv_jpeg_coefs){
        .blocks =
            (const int16_t *)(img->data + variant * rd_jpeg_coef_bytes(img->width, img->height)),
        .width = img->width,
        .height = img->height,
        .quality = img->coef_quality[variant]};
}

/* A whole variant: pixels with TurboJPEG, coefficients with libjpeg's entropy coder. Lock not
 * held; returns with it held. */
static void run_whole(srv_encoder_pool *p, tjhandle tj, srv_jpeg_encoder *enc, srv_frame *f,
                      unsigned variant)
{
    srv_jpeg *v = &f->variants[variant];
    const srv_image *img = f->image;
    unsigned char *out = NULL;
    size_t size = 0;
    double t0 = srv_mono_ms();
    if (img->coef_sets) {
        srv_jpeg_coefs c = coefs_of(f, variant);
        srv_jpeg_plan whole;
        srv_jpeg_buf buf = {0};
        srv_jpeg_result r = srv_jpeg_plan_make(&whole, img->width, img->height, 1, 1);
        if (r == SRV_JPEG_OK) r = srv_jpeg_encode_coefs(enc, &whole, &c, 0, &buf);
        if (r == SRV_JPEG_OK) {
            out = buf.data; /* the buffer moves to the variant */
            size = buf.size;
        } else {
            srv_error("encoder", "JPEG entropy coding failed: %s%s%s", srv_jpeg_strerror(r),
                      r == SRV_JPEG_ERR_ENCODE ? ": " : "",
                      r == SRV_JPEG_ERR_ENCODE ? srv_jpeg_encoder_error(enc) : "");
            srv_jpeg_buf_free(&buf);
        }
    } else {
        /* into a buffer of the worst case, so that TurboJPEG never reallocates it (the variants
         * are freed with free()) */
        unsigned long cap = tjBufSize((int)img->width, (int)img->height, TJSAMP_420);
        unsigned long tj_size = cap; /* the buffer's size going in, the JPEG's coming out */
        out = cap != (unsigned long)-1 ? malloc(cap) : NULL;
        int rc = tj && out ? tjCompress2(tj, img->data, (int)img->width, 0, (int)img->height,
                                         TJPF_RGBA, &out, &tj_size, TJSAMP_420, (int)v->quality,
                                         TJFLAG_FASTDCT | TJFLAG_NOREALLOC)
                           : -1;
        size = tj_size;
        if (rc != 0) {
            srv_error("encoder", "JPEG encoding failed: %s",
                      tj ? tjGetErrorStr2(tj) : "no encoder");
            free(out);
            out = NULL;
        }
    }
    double ms = srv_mono_ms() - t0;
    pthread_mutex_lock(&p->mu);
    if (out) {
        v->data = out;
        v->size = size;
        count_jpeg(p, size, ms, false, img->coef_sets > 0);
    }
}

/* One stripe of a variant; the thread that finishes the variant's last stripe joins them. Lock
 * not held; returns with it held. */
static void run_stripe(srv_encoder_pool *p, srv_jpeg_encoder *enc, srv_frame *f, unsigned variant,
                       unsigned stripe)
{
    srv_stripe_set *s = &f->stripe_sets[variant];
    srv_jpeg *v = &f->variants[variant];
    srv_jpeg_coefs c;
    if (f->image->coef_sets) c = coefs_of(f, variant);
    srv_jpeg_result r = f->image->coef_sets
                            ? srv_jpeg_encode_coefs(enc, &s->plan, &c, stripe, &s->bufs[stripe])
                            : srv_jpeg_encode_stripe(enc, &s->plan, f->image->data, v->quality,
                                                     stripe, &s->bufs[stripe]);
    pthread_mutex_lock(&p->mu);
    if (r != SRV_JPEG_OK) {
        srv_error("encoder", "JPEG stripe %u encoding failed: %s%s%s", stripe, srv_jpeg_strerror(r),
                  r == SRV_JPEG_ERR_ENCODE ? ": " : "",
                  r == SRV_JPEG_ERR_ENCODE ? srv_jpeg_encoder_error(enc) : "");
        s->failed = true;
    }
    /* the last stripe of a variant nobody dropped: every other stripe's buffer is final (their
     * jobs wrote them before taking this lock) and no thread touches them again but this one */
    if (--s->left > 0 || s->failed || f->abandoned) return;
    double start_ms = s->start_ms;
    pthread_mutex_unlock(&p->mu);

    size_t cap = srv_jpeg_join_bound(&s->plan, s->bufs), size = 0;
    uint8_t *out = malloc(cap ? cap : 1);
    if (!out) abort(); /* out of memory */
    r = srv_jpeg_join(&s->plan, s->bufs, out, cap, &size);
    for (unsigned i = 0; i < s->plan.stripe_count; i++)
        srv_jpeg_buf_free(&s->bufs[i]);
    double ms = srv_mono_ms() - start_ms;
    if (r != SRV_JPEG_OK) {
        srv_error("encoder", "joining JPEG stripes failed: %s", srv_jpeg_strerror(r));
        free(out);
        out = NULL;
    }
    pthread_mutex_lock(&p->mu);
    if (out) {
        v->data = out;
        v->size = size;
        count_jpeg(p, size, ms, true, f->image->coef_sets > 0);
    }
}

static void *encoder_main(void *arg)
{
    srv_encoder_pool *p = arg;
    tjhandle tj = tjInitCompress();
    if (!tj) srv_error("encoder", "tjInitCompress failed: %s", tjGetErrorStr());
    srv_jpeg_encoder *enc = srv_jpeg_encoder_create();
    pthread_mutex_lock(&p->mu);
    for (;;) {
        while (!p->stop && !p->head)
            pthread_cond_wait(&p->cv, &p->mu);
        if (p->stop) break;
        job *j = p->head;
        p->head = j->next;
        if (!p->head) p->tail = NULL;
        srv_frame *f = j->frame;
        unsigned variant = j->variant, stripe = j->stripe;
        free(j);
        if (f->stripe_sets) {
            srv_stripe_set *s = &f->stripe_sets[variant];
            if (!s->started) {
                s->started = true;
                s->start_ms = srv_mono_ms();
            }
            pthread_mutex_unlock(&p->mu);
            run_stripe(p, enc, f, variant, stripe);
        } else {
            pthread_mutex_unlock(&p->mu);
            run_whole(p, tj, enc, f, variant);
        }
        job_done(p, f);
    }
    pthread_mutex_unlock(&p->mu);
    srv_jpeg_encoder_destroy(enc);
    if (tj) tjDestroy(tj);
    return NULL;
}

srv_encoder_pool *srv_encoder_pool_create(unsigned threads)
{
    srv_encoder_pool *p = xcalloc(1, sizeof *p);
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->cv, NULL);
    pthread_cond_init(&p->published, NULL);
    p->threads = xcalloc(threads ? threads : 2, sizeof *p->threads);
    unsigned want = threads ? threads : 2;
    for (unsigned i = 0; i < want; i++) {
        if (pthread_create(&p->threads[i], NULL, encoder_main, p) != 0) {
            srv_error("encoder", "cannot start encoder thread %u", i);
            srv_encoder_pool_destroy(p);
            return NULL;
        }
        p->thread_count++;
    }
    return p;
}

void srv_encoder_pool_destroy(srv_encoder_pool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->stop = true;
    p->listener = NULL;
    pthread_cond_broadcast(&p->cv);
    pthread_mutex_unlock(&p->mu);
    for (unsigned i = 0; i < p->thread_count; i++)
        pthread_join(p->threads[i], NULL);
    /* jobs never started: drop them (frames are freed with their last job) */
    while (p->head) {
        job *j = p->head;
        p->head = j->next;
        job_drop(p, j);
    }
    for (unsigned i = 0; i < p->latest_count; i++)
        srv_frame_unref(p->latest[i].frame);
    free(p->latest);
    free(p->threads);
    srv_image_pool_drain();
    pthread_cond_destroy(&p->published);
    pthread_cond_destroy(&p->cv);
    pthread_mutex_destroy(&p->mu);
    free(p);
}

void srv_encoder_pool_set_listener(srv_encoder_pool *p, srv_frame_listener fn, void *user)
{
    pthread_mutex_lock(&p->mu);
    p->listener = fn;
    p->listener_user = user;
    pthread_mutex_unlock(&p->mu);
}

void srv_encoder_set_stripe_min_pixels(srv_encoder_pool *p, unsigned pixels)
{
    pthread_mutex_lock(&p->mu);
    p->stripe_min_pixels = pixels;
    pthread_mutex_unlock(&p->mu);
}

void srv_encoder_set_caps(srv_encoder_pool *p, uint32_t mask)
{
    pthread_mutex_lock(&p->mu);
    p->caps = mask;
    pthread_mutex_unlock(&p->mu);
}

/* srv_encoder_qualities with the lock held */
static unsigned qualities_locked(const srv_encoder_pool *p, unsigned base_quality,
                                 unsigned q[SRV_MAX_VARIANTS])
{
    unsigned n = 0;
    for (unsigned i = 0; i < SRV_CAP_STEPS; i++) {
        if (!(p->caps & (1u << i))) continue;
        unsigned c = SRV_CAP_MIN + 10 * i;
        unsigned v = c < base_quality ? c : base_quality;
        if (n == 0 || q[n - 1] != v) q[n++] = v;
    }
    if (n == 0 || q[n - 1] != base_quality) q[n++] = base_quality;
    return n;
}

unsigned srv_encoder_qualities(srv_encoder_pool *p, unsigned base_quality,
                               unsigned q[SRV_MAX_VARIANTS])
{
    pthread_mutex_lock(&p->mu);
    unsigned n = qualities_locked(p, base_quality, q);
    pthread_mutex_unlock(&p->mu);
    return n;
}

void srv_encoder_submit(srv_encoder_pool *p, srv_image *img, const srv_frame_info *info,
                        unsigned base_quality)
{
    srv_frame *f = xcalloc(1, sizeof *f);
    atomic_init(&f->refs, 1);
    f->info = *info;
    f->width = img->width;
    f->height = img->height;
    f->image = srv_image_ref(img);

    pthread_mutex_lock(&p->mu);
    /* qualities: base, and min(base, cap) per cap, ascending and unique; coefficients come
     * with theirs */
    unsigned q[SRV_MAX_VARIANTS], n;
    if (info->video_only) {
        n = 0; /* published at once below, for the video encoders */
    } else if (img->coef_sets) {
        n = img->coef_sets < SRV_MAX_VARIANTS ? img->coef_sets : SRV_MAX_VARIANTS;
        memcpy(q, img->coef_quality, n * sizeof q[0]);
    } else {
        n = qualities_locked(p, base_quality, q);
    }
    f->variant_count = n;
    for (unsigned i = 0; i < n; i++)
        f->variants[i].quality = q[i];

    /* large images: every variant in stripes, one per thread */
    unsigned min_px = p->stripe_min_pixels ? p->stripe_min_pixels : SRV_STRIPE_MIN_PIXELS;
    srv_jpeg_plan plan;
    unsigned stripes = 1;
    if (n > 0 && p->thread_count > 1 && (uint64_t)img->width * img->height >= min_px &&
        srv_jpeg_plan_make(&plan, img->width, img->height, p->thread_count,
                           SRV_STRIPE_MIN_MCU_ROWS) == SRV_JPEG_OK &&
        plan.stripe_count > 1) {
        stripes = plan.stripe_count;
        f->stripe_sets = xcalloc(n, sizeof *f->stripe_sets);
        for (unsigned i = 0; i < n; i++) {
            f->stripe_sets[i].plan = plan;
            f->stripe_sets[i].bufs = xcalloc(stripes, sizeof *f->stripe_sets[i].bufs);
            f->stripe_sets[i].left = stripes;
        }
    }
    f->remaining = n * stripes;

    /* latest frame wins: jobs of the view's older frames that no thread has started are
     * dropped (other views' frames are not this one's to replace); a striped frame whose first
     * stripe has started keeps its other stripes, so that work is not thrown away */
    job **link = &p->head;
    p->tail = NULL;
    while (*link) {
        job *j = *link;
        const srv_frame *old = j->frame;
        bool started = old->stripe_sets && old->stripe_sets[0].started; /* jobs run in order */
        if (old->info.view_id == info->view_id && old->info.frame_id < info->frame_id && !started) {
            *link = j->next;
            job_drop(p, j);
        } else {
            p->tail = j;
            link = &j->next;
        }
    }
    if (n == 0) { /* video only: nothing to encode */
        p->stats.frames_video_only++;
        f->remaining = 1;
        job_done(p, f);
        pthread_mutex_unlock(&p->mu);
        return;
    }
    /* variant after variant, each one's stripes top to bottom */
    for (unsigned k = 0; k < n * stripes; k++) {
        job *j = xcalloc(1, sizeof *j);
        j->frame = f;
        j->variant = k / stripes;
        j->stripe = k % stripes;
        if (p->tail)
            p->tail->next = j;
        else
            p->head = j;
        p->tail = j;
    }
    pthread_cond_broadcast(&p->cv);
    pthread_mutex_unlock(&p->mu);
}

srv_frame *srv_encoder_latest(srv_encoder_pool *p, uint32_t view_id)
{
    pthread_mutex_lock(&p->mu);
    srv_frame **slot = latest_slot(p, view_id, false);
    srv_frame *f = slot && *slot ? srv_frame_ref(*slot) : NULL;
    pthread_mutex_unlock(&p->mu);
    return f;
}

srv_frame *srv_encoder_wait_frame(srv_encoder_pool *p, uint32_t view_id, uint64_t after_id,
                                  unsigned timeout_ms)
{
    struct timespec deadline;
    clock_gettime(CLOCK_REALTIME, &deadline);
    long long ns = deadline.tv_nsec + (long long)timeout_ms * 1000000LL;
    deadline.tv_sec += ns / 1000000000LL;
    deadline.tv_nsec = ns % 1000000000LL;
    pthread_mutex_lock(&p->mu);
    srv_frame *f = NULL;
    for (;;) {
        srv_frame **slot = latest_slot(p, view_id, false);
        /* a frame with JPEG (not one made for video viewers only) */
        if (slot && *slot && (*slot)->info.frame_id > after_id && (*slot)->variant_count > 0) {
            f = srv_frame_ref(*slot);
            break;
        }
        if (p->stop || pthread_cond_timedwait(&p->published, &p->mu, &deadline) != 0) break;
    }
    pthread_mutex_unlock(&p->mu);
    return f;
}

void srv_encoder_forget_view(srv_encoder_pool *p, uint32_t view_id)
{
    pthread_mutex_lock(&p->mu);
    for (unsigned i = 0; i < p->latest_count; i++) {
        if (p->latest[i].view_id != view_id) continue;
        srv_frame_unref(p->latest[i].frame);
        p->latest[i] = p->latest[--p->latest_count];
        break;
    }
    pthread_mutex_unlock(&p->mu);
}

void srv_encoder_get_stats(srv_encoder_pool *p, srv_encoder_stats *out)
{
    pthread_mutex_lock(&p->mu);
    *out = p->stats;
    pthread_mutex_unlock(&p->mu);
}
