/* views.c: the view table (see views.h). */
#include "server/render/views.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void srv_views_init(srv_views *vs, unsigned max_views, unsigned max_pixels,
                    uint64_t max_total_pixels)
{
    *vs = (srv_views){
        .max_views = max_views, .max_pixels = max_pixels, .max_total_pixels = max_total_pixels};
}

static void free_view(srv_view *v)
{
    if (v->gpu_ok) rd_view_destroy(&v->gpu);
    srv_image_unref(v->last_image);
    free(v);
}

void srv_views_dispose(srv_views *vs)
{
    for (unsigned i = 0; i < vs->count; i++)
        free_view(vs->items[i]);
    free(vs->items);
    vs->items = NULL;
    vs->count = vs->cap = 0;
}

int srv_views_index(const srv_views *vs, uint32_t id)
{
    for (unsigned i = 0; i < vs->count; i++)
        if (vs->items[i]->id == id) return (int)i;
    return -1;
}

srv_view *srv_views_find(srv_views *vs, uint32_t id)
{
    int i = srv_views_index(vs, id);
    return i < 0 ? NULL : vs->items[i];
}

void srv_views_fit(const srv_views *vs, uint32_t id, unsigned want_w, unsigned want_h, unsigned *w,
                   unsigned *h)
{
    uint64_t others = 0;
    for (unsigned i = 0; i < vs->count; i++)
        if (vs->items[i]->id != id) others += (uint64_t)vs->items[i]->width * vs->items[i]->height;
    double cap = vs->max_pixels;
    double left = vs->max_total_pixels > others ? (double)(vs->max_total_pixels - others) : 0;
    if (left < cap) cap = left;
    if (cap < SRV_SIDE_MIN * SRV_SIDE_MIN) cap = SRV_SIDE_MIN * SRV_SIDE_MIN;
    double fw = want_w ? want_w : 1, fh = want_h ? want_h : 1;
    if (fw * fh > cap) {
        double k = sqrt(cap / (fw * fh));
        fw = floor(fw * k), fh = floor(fh * k);
    }
    *w = fw < SRV_SIDE_MIN ? SRV_SIDE_MIN : fw > SRV_SIDE_MAX ? SRV_SIDE_MAX : (unsigned)fw;
    *h = fh < SRV_SIDE_MIN ? SRV_SIDE_MIN : fh > SRV_SIDE_MAX ? SRV_SIDE_MAX : (unsigned)fh;
}

srv_view *srv_views_add(srv_views *vs, uint32_t id, unsigned width, unsigned height,
                        const srv_camera *camera)
{
    if (vs->count >= vs->max_views || srv_views_find(vs, id)) return NULL;
    if (vs->count == vs->cap) {
        vs->cap = vs->cap ? 2 * vs->cap : 8;
        vs->items = realloc(vs->items, vs->cap * sizeof *vs->items);
        if (!vs->items) abort();
    }
    srv_view *v = calloc(1, sizeof *v);
    if (!v) abort();
    v->id = id;
    v->camera = *camera;
    srv_views_fit(vs, id, width, height, &v->width, &v->height);
    v->dirty = true;
    v->last_input_ms = -1e9; /* the first frame is a still */
    v->last_render_ms = -1e9;
    vs->items[vs->count++] = v;
    return v;
}

void srv_views_remove(srv_views *vs, uint32_t id)
{
    int i = srv_views_index(vs, id);
    if (i < 0) return;
    free_view(vs->items[i]);
    memmove(&vs->items[i], &vs->items[i + 1], (vs->count - i - 1) * sizeof *vs->items);
    vs->count--;
    if (vs->cursor > (unsigned)i) vs->cursor--;
    if (vs->cursor >= vs->count) vs->cursor = 0;
}

void srv_views_mark_all(srv_views *vs, bool world_tick)
{
    for (unsigned i = 0; i < vs->count; i++) {
        vs->items[i]->dirty = true;
        if (world_tick) {
            vs->items[i]->behind_world = true;
            vs->items[i]->renders_since_tick = 0;
        }
    }
}

void srv_view_info_of(const srv_view *v, srv_view_info *out)
{
    *out = (srv_view_info){.id = v->id,
                           .http = v->id == 0,
                           .width = v->width,
                           .height = v->height,
                           .watchers = v->watchers,
                           .camera = v->camera};
}

bool srv_view_set_caps(srv_view *v, unsigned jpeg_cap, unsigned fps_cap)
{
    if (v->jpeg_cap == jpeg_cap && v->fps_cap == fps_cap) return false;
    /* re-encode the last image under the new cap (the scheduler waits for owed frames first) */
    if (v->last_frame_id && jpeg_cap != v->jpeg_cap) v->need_still = true;
    v->jpeg_cap = jpeg_cap;
    v->fps_cap = fps_cap;
    return true;
}

unsigned srv_view_quality(const srv_view *v, unsigned base)
{
    return v->jpeg_cap && v->jpeg_cap < base ? v->jpeg_cap : base;
}

unsigned srv_views_pt_samples_min(const srv_views *vs)
{
    unsigned watched = UINT_MAX, all = UINT_MAX;
    for (unsigned i = 0; i < vs->count; i++) {
        const srv_view *v = vs->items[i];
        if (v->pt_samples < all) all = v->pt_samples;
        if ((v->watchers || v->requests) && v->pt_samples < watched) watched = v->pt_samples;
    }
    return watched != UINT_MAX ? watched : all != UINT_MAX ? all : 0;
}
