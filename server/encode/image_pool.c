/* image_pool.c: reference-counted frame images and the pixel buffers they recycle. See
 * image_pool.h. */
#include "server/encode/image_pool.h"

#include <pthread.h>
#include <stdlib.h>

/* Freed pixel buffers kept for reuse: a frame of the same size follows soon, and a fresh
 * allocation of megabytes costs page faults on every first touch (about as much as the copy). */
#define IMAGE_POOL 32
static pthread_mutex_t pool_mu = PTHREAD_MUTEX_INITIALIZER;
static struct {
    uint8_t *data;
    size_t cap;
} pool[IMAGE_POOL];
static unsigned pool_count, pool_evict;

static uint8_t *pixels_take(size_t need, size_t *cap)
{
    uint8_t *p = NULL;
    pthread_mutex_lock(&pool_mu);
    for (unsigned i = 0; i < pool_count; i++) {
        if (pool[i].cap >= need && pool[i].cap <= 2 * need) {
            p = pool[i].data;
            *cap = pool[i].cap;
            pool[i] = pool[--pool_count];
            break;
        }
    }
    pthread_mutex_unlock(&pool_mu);
    if (!p) {
        p = malloc(need ? need : 1);
        if (!p) abort();
        *cap = need;
    }
    return p;
}

static void pixels_give(uint8_t *p, size_t cap)
{
    uint8_t *evicted = NULL;
    pthread_mutex_lock(&pool_mu);
    if (pool_count == IMAGE_POOL) {
        /* full: the newest buffer replaces one in turn, so buffers of a size no longer rendered
         * (a view was resized or left) age out instead of blocking the pool */
        evicted = pool[pool_evict].data;
        pool[pool_evict].data = p;
        pool[pool_evict].cap = cap;
        pool_evict = (pool_evict + 1) % IMAGE_POOL;
    } else {
        pool[pool_count].data = p;
        pool[pool_count++].cap = cap;
    }
    pthread_mutex_unlock(&pool_mu);
    free(evicted);
}

void srv_image_pool_drain(void)
{
    pthread_mutex_lock(&pool_mu);
    while (pool_count)
        free(pool[--pool_count].data);
    pthread_mutex_unlock(&pool_mu);
}

/* An image of one reference and no pixels yet. */
static srv_image *image_create(unsigned width, unsigned height)
{
    srv_image *img = calloc(1, sizeof *img);
    if (!img) abort(); /* out of memory */
    atomic_init(&img->refs, 1);
    img->width = width;
    img->height = height;
    return img;
}

srv_image *srv_image_alloc(unsigned width, unsigned height, size_t bytes)
{
    srv_image *img = image_create(width, height);
    img->data = pixels_take(bytes, &img->cap);
    return img;
}

srv_image *srv_image_new(unsigned width, unsigned height)
{
    return srv_image_alloc(width, height, (size_t)width * height * 4);
}

srv_image *srv_image_wrap(unsigned width, unsigned height, uint8_t *data,
                          void (*release)(void *ctx, unsigned token), void *ctx, unsigned token)
{
    srv_image *img = image_create(width, height);
    img->data = data;
    img->release = release;
    img->release_ctx = ctx;
    img->release_token = token;
    return img;
}

srv_image *srv_image_ref(srv_image *img)
{
    atomic_fetch_add(&img->refs, 1);
    return img;
}

void srv_image_unref(srv_image *img)
{
    if (img && atomic_fetch_sub(&img->refs, 1) == 1) {
        if (img->release)
            img->release(img->release_ctx, img->release_token);
        else
            pixels_give(img->data, img->cap);
        free(img);
    }
}
