/* scene.c: the CPU scene model (see scene.h).
 *
 * rd_scene has no capacity fields: each array's capacity is implied by its count (0, then 8,
 * 16, 32 ... elements) and the builders grow it geometrically. Code may lower a count
 * directly (the allocation stays large enough) but must add elements through the builders.
 */
#include "renderer/scene/scene.h"

#include <assert.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/deform.h"
#include "renderer/scene/xform.h"

/* Above this many instance vertices rd_scene_update bounds each instance by its mesh's
 * transformed object-space box (conservative) instead of transforming every vertex. */
#define RD_EXACT_BOUNDS_MAX_VERTICES (64u * 1024u * 1024u)

static void *xrealloc(void *p, size_t count, size_t size)
{
    if (count == 0) {
        free(p);
        return NULL;
    }
    if (size != 0 && count > SIZE_MAX / size) goto oom;
    void *q = realloc(p, count * size);
    if (q) return q;
oom:
    fprintf(stderr, "probecast: out of memory (%zu x %zu bytes)\n", count, size);
    abort();
}

static void *xcalloc(size_t count, size_t size)
{
    if (count == 0 || size == 0) return NULL;
    void *p = calloc(count, size);
    if (!p) {
        fprintf(stderr, "probecast: out of memory (%zu x %zu bytes)\n", count, size);
        abort();
    }
    return p;
}

static char *xstrdup(const char *s)
{
    if (!s) return NULL;
    size_t n = strlen(s) + 1;
    char *d = xrealloc(NULL, n, 1);
    memcpy(d, s, n);
    return d;
}

/* Capacity implied by an element count (see the top of the file). */
static size_t implied_capacity(size_t count)
{
    if (count == 0) return 0;
    size_t cap = 8;
    while (cap < count)
        cap *= 2;
    return cap;
}

/* Makes room for one more element of *arr and returns its index (the count is bumped). */
static uint32_t grow(void **arr, uint32_t *count, size_t size)
{
    size_t n = *count;
    if (n == UINT32_MAX) {
        fprintf(stderr, "probecast: scene array overflow\n");
        abort();
    }
    if (n + 1 > implied_capacity(n)) *arr = xrealloc(*arr, implied_capacity(n + 1), size);
    return (*count)++;
}

rd_material rd_material_default(void)
{
    return (rd_material){
        .name = "default",
        .base_color = {1.0f, 1.0f, 1.0f, 1.0f},
        .roughness = 1.0f,
        .normal_scale = 1.0f,
        .occlusion_strength = 1.0f,
        .base_color_texture = -1,
        .emissive_texture = -1,
        .metallic_roughness_texture = -1,
        .normal_texture = -1,
        .occlusion_texture = -1,
        .alpha_mode = RD_ALPHA_OPAQUE,
        .alpha_cutoff = 0.5f,
        .double_sided = false,
    };
}

void rd_scene_init(rd_scene *s)
{
    memset(s, 0, sizeof *s);
    rd_material def = rd_material_default();
    rd_scene_add_material(s, &def);
    for (int k = 0; k < 3; k++) {
        s->bounds_min[k] = -0.5f;
        s->bounds_max[k] = 0.5f;
    }
}

void rd_mesh_free_arrays(rd_mesh *m)
{
    free(m->name);
    free(m->positions);
    free(m->normals);
    free(m->uvs);
    free(m->tangents);
    free(m->material);
    rd_mesh_deform_free(m->deform);
}

void rd_scene_destroy(rd_scene *s)
{
    if (!s) return;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        rd_mesh_free_arrays(&s->meshes[i]);
    free(s->meshes);
    for (uint32_t i = 0; i < s->node_count; i++) {
        free(s->nodes[i].name);
        free(s->nodes[i].weights);
    }
    free(s->nodes);
    for (uint32_t i = 0; i < s->skin_count; i++) {
        free(s->skins[i].name);
        free(s->skins[i].joints);
        free(s->skins[i].inverse_bind);
    }
    free(s->skins);
    for (uint32_t i = 0; i < s->material_count; i++)
        free(s->materials[i].name);
    free(s->materials);
    for (uint32_t i = 0; i < s->texture_count; i++)
        free(s->textures[i].rgba);
    free(s->textures);
    for (uint32_t i = 0; i < s->light_count; i++)
        free(s->lights[i].name);
    free(s->lights);
    for (uint32_t i = 0; i < s->camera_count; i++)
        free(s->cameras[i].name);
    free(s->cameras);
    free(s->instances);
    for (uint32_t i = 0; i < s->animation_count; i++) {
        rd_animation *a = &s->animations[i];
        free(a->name);
        for (uint32_t k = 0; k < a->sampler_count; k++) {
            free(a->samplers[k].times);
            free(a->samplers[k].values);
        }
        free(a->samplers);
        free(a->channels);
    }
    free(s->animations);
    for (uint32_t i = 0; i < s->warning_count; i++)
        free(s->warnings[i]);
    free(s->warnings);
    memset(s, 0, sizeof *s);
}

uint32_t rd_scene_add_material(rd_scene *s, const rd_material *m)
{
    uint32_t i = grow((void **)&s->materials, &s->material_count, sizeof *s->materials);
    s->materials[i] = *m;
    s->materials[i].name = xstrdup(m->name);
    return i;
}

uint32_t rd_scene_add_texture(rd_scene *s, const rd_texture *t)
{
    uint32_t i = grow((void **)&s->textures, &s->texture_count, sizeof *s->textures);
    s->textures[i] = *t;
    return i;
}

uint32_t rd_scene_add_mesh(rd_scene *s, const char *name, uint32_t tri_count)
{
    uint32_t i = grow((void **)&s->meshes, &s->mesh_count, sizeof *s->meshes);
    rd_mesh *m = &s->meshes[i];
    memset(m, 0, sizeof *m);
    m->name = xstrdup(name);
    m->tri_count = tri_count;
    m->positions = xcalloc((size_t)tri_count * 9, sizeof(float));
    m->normals = xcalloc((size_t)tri_count * 9, sizeof(float));
    m->uvs = xcalloc((size_t)tri_count * 6, sizeof(float));
    m->material = xcalloc(tri_count, sizeof(uint32_t));
    return i;
}

uint32_t rd_scene_add_node(rd_scene *s, const rd_node *n)
{
    uint32_t i = grow((void **)&s->nodes, &s->node_count, sizeof *s->nodes);
    s->nodes[i] = *n;
    s->nodes[i].name = xstrdup(n->name);
    s->nodes[i].weights = n->weight_count ? xcalloc(n->weight_count, sizeof(float)) : NULL;
    if (n->weight_count) memcpy(s->nodes[i].weights, n->weights, n->weight_count * sizeof(float));
    return i;
}

uint32_t rd_scene_add_light(rd_scene *s, const rd_light *l)
{
    uint32_t i = grow((void **)&s->lights, &s->light_count, sizeof *s->lights);
    s->lights[i] = *l;
    s->lights[i].name = xstrdup(l->name);
    return i;
}

void rd_scene_remove_light(rd_scene *s, uint32_t index)
{
    if (index >= s->light_count) return;
    free(s->lights[index].name);
    memmove(&s->lights[index], &s->lights[index + 1],
            (s->light_count - index - 1) * sizeof *s->lights);
    s->light_count--;
}

uint32_t rd_scene_add_camera(rd_scene *s, const rd_camera *c)
{
    uint32_t i = grow((void **)&s->cameras, &s->camera_count, sizeof *s->cameras);
    s->cameras[i] = *c;
    s->cameras[i].name = xstrdup(c->name);
    return i;
}

static void *copy_array(const void *src, size_t count, size_t size)
{
    void *d = xcalloc(count, size);
    if (d) memcpy(d, src, count * size);
    return d;
}

uint32_t rd_scene_add_skin(rd_scene *s, const rd_skin *k)
{
    uint32_t i = grow((void **)&s->skins, &s->skin_count, sizeof *s->skins);
    rd_skin *d = &s->skins[i];
    d->name = xstrdup(k->name);
    d->joint_count = k->joint_count;
    d->joints = copy_array(k->joints, k->joint_count, sizeof *d->joints);
    d->inverse_bind = copy_array(k->inverse_bind, (size_t)k->joint_count * 16, sizeof(float));
    return i;
}

uint32_t rd_scene_add_animation(rd_scene *s, const rd_animation *a)
{
    uint32_t i = grow((void **)&s->animations, &s->animation_count, sizeof *s->animations);
    rd_animation *d = &s->animations[i];
    memset(d, 0, sizeof *d);
    d->name = xstrdup(a->name);
    d->duration = a->duration > 0.0f && isfinite(a->duration) ? a->duration : 0.0f;
    d->sampler_count = a->sampler_count;
    d->samplers = xcalloc(a->sampler_count, sizeof *d->samplers);
    for (uint32_t k = 0; k < a->sampler_count; k++) {
        const rd_anim_sampler *src = &a->samplers[k];
        assert(src->key_count >= 1 && src->components >= 1 &&
               src->components <= RD_ANIM_MAX_COMPONENTS);
        assert(src->interpolation <= RD_INTERP_CUBICSPLINE);
        size_t values = (size_t)src->key_count * src->components *
                        (src->interpolation == RD_INTERP_CUBICSPLINE ? 3 : 1);
        d->samplers[k] = *src;
        d->samplers[k].times = copy_array(src->times, src->key_count, sizeof(float));
        d->samplers[k].values = copy_array(src->values, values, sizeof(float));
        float last = src->times[src->key_count - 1];
        if (last > d->duration) d->duration = last;
    }
    d->channel_count = a->channel_count;
    d->channels = copy_array(a->channels, a->channel_count, sizeof *d->channels);
    for (uint32_t k = 0; k < a->channel_count; k++)
        assert(a->channels[k].sampler < a->sampler_count && a->channels[k].path <= RD_ANIM_WEIGHTS);
    return i;
}

void rd_scene_warn(rd_scene *s, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) n = 0;
    char *msg = xrealloc(NULL, (size_t)n + 1, 1);
    va_start(ap, fmt);
    vsnprintf(msg, (size_t)n + 1, fmt, ap);
    va_end(ap);
    uint32_t i = grow((void **)&s->warnings, &s->warning_count, sizeof *s->warnings);
    s->warnings[i] = msg;
}

void rd_mesh_fill_flat_normals(rd_mesh *m)
{
    static const float up[3] = {0.0f, 0.0f, 1.0f};
    for (uint32_t t = 0; t < m->tri_count; t++) {
        const float *p = &m->positions[(size_t)t * 9];
        float *n = &m->normals[(size_t)t * 9];
        bool need = false;
        for (int v = 0; v < 3; v++) {
            double x = n[v * 3], y = n[v * 3 + 1], z = n[v * 3 + 2];
            double len2 = x * x + y * y + z * z;
            if (!(len2 > 0.0) || !isfinite(len2)) need = true;
        }
        if (!need) continue;
        float e1[3], e2[3], g[3], flat[3];
        rd_vec3_sub(e1, p + 3, p);
        rd_vec3_sub(e2, p + 6, p);
        rd_vec3_cross(g, e1, e2); /* counter-clockwise front face */
        rd_vec3_normalize(flat, g, up);
        for (int v = 0; v < 3; v++) {
            double x = n[v * 3], y = n[v * 3 + 1], z = n[v * 3 + 2];
            double len2 = x * x + y * y + z * z;
            if (!(len2 > 0.0) || !isfinite(len2)) memcpy(&n[v * 3], flat, sizeof flat);
        }
    }
}

void rd_node_local_matrix(const rd_node *n, float out[16])
{
    if (n->has_matrix)
        memcpy(out, n->matrix, 16 * sizeof(float));
    else
        rd_mat4_from_trs(out, n->translation, n->rotation, n->scale);
}

static bool fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return false;
}

/* World matrices, parents first, with an explicit stack (no recursion on deep chains). */
static bool update_world(rd_scene *s, char *err, size_t errlen)
{
    for (uint32_t i = 0; i < s->node_count; i++) {
        int32_t p = s->nodes[i].parent;
        if (p < -1 || (p >= 0 && (uint32_t)p >= s->node_count))
            return fail(err, errlen, "node %u has parent %d, but there are only %u nodes", i,
                        (int)p, s->node_count);
        if (p >= 0 && (uint32_t)p == i) return fail(err, errlen, "node %u is its own parent", i);
        int32_t mesh = s->nodes[i].mesh;
        if (mesh < -1 || (mesh >= 0 && (uint32_t)mesh >= s->mesh_count))
            return fail(err, errlen, "node %u refers to mesh %d, but there are only %u meshes", i,
                        (int)mesh, s->mesh_count);
    }
    /* state: 0 = not visited, 1 = on the current chain, 2 = world matrix done */
    uint8_t *state = xcalloc(s->node_count ? s->node_count : 1, 1);
    uint32_t *chain = xcalloc(s->node_count ? s->node_count : 1, sizeof(uint32_t));
    bool ok = true;
    for (uint32_t i = 0; i < s->node_count && ok; i++) {
        uint32_t len = 0;
        int32_t j = (int32_t)i;
        while (j >= 0 && state[j] == 0) {
            state[j] = 1;
            chain[len++] = (uint32_t)j;
            j = s->nodes[j].parent;
        }
        if (j >= 0 && state[j] == 1) {
            ok = fail(err, errlen, "the node hierarchy contains a cycle through node %d", (int)j);
            break;
        }
        /* chain[len - 1] is a root or a child of a finished node */
        while (len > 0) {
            rd_node *n = &s->nodes[chain[--len]];
            float local[16];
            rd_node_local_matrix(n, local);
            if (n->parent >= 0)
                rd_mat4_mul(n->world, s->nodes[n->parent].world, local);
            else
                memcpy(n->world, local, sizeof local);
            state[chain[len]] = 2;
        }
    }
    free(state);
    free(chain);
    return ok;
}

static void place(const rd_node *n, float pos[3], float dir[3], float up[3])
{
    static const float minus_z[3] = {0.0f, 0.0f, -1.0f};
    static const float plus_y[3] = {0.0f, 1.0f, 0.0f};
    float d[3];
    rd_vec3_set(pos, n->world[12], n->world[13], n->world[14]);
    rd_mat4_transform_dir(n->world, minus_z, d);
    rd_vec3_normalize(dir, d, minus_z);
    if (up) {
        rd_mat4_transform_dir(n->world, plus_y, d);
        rd_vec3_normalize(up, d, plus_y);
    }
}

static void grow_box(float bmin[3], float bmax[3], const float p[3])
{
    for (int k = 0; k < 3; k++) {
        if (p[k] < bmin[k]) bmin[k] = p[k];
        if (p[k] > bmax[k]) bmax[k] = p[k];
    }
}

static void update_bounds(rd_scene *s)
{
    float bmin[3] = {INFINITY, INFINITY, INFINITY};
    float bmax[3] = {-INFINITY, -INFINITY, -INFINITY};
    uint64_t vertices = 0;
    s->tri_total = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        s->tri_total += s->meshes[s->instances[i].mesh].tri_count;
        vertices += 3ull * s->meshes[s->instances[i].mesh].tri_count;
    }
    bool exact = vertices <= RD_EXACT_BOUNDS_MAX_VERTICES;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rd_mesh *m = &s->meshes[s->instances[i].mesh];
        const float *w = s->nodes[s->instances[i].node].world;
        if (exact) {
            for (size_t v = 0; v < (size_t)m->tri_count * 3; v++) {
                float p[3];
                if (!rd_vec3_isfinite(&m->positions[v * 3])) continue;
                rd_mat4_transform_point(w, &m->positions[v * 3], p);
                if (rd_vec3_isfinite(p)) grow_box(bmin, bmax, p);
            }
            continue;
        }
        /* conservative: the eight corners of the object-space box */
        float omin[3] = {INFINITY, INFINITY, INFINITY};
        float omax[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t v = 0; v < (size_t)m->tri_count * 3; v++)
            if (rd_vec3_isfinite(&m->positions[v * 3])) grow_box(omin, omax, &m->positions[v * 3]);
        if (!(omin[0] <= omax[0])) continue;
        for (int c = 0; c < 8; c++) {
            float q[3] = {(c & 1) ? omax[0] : omin[0], (c & 2) ? omax[1] : omin[1],
                          (c & 4) ? omax[2] : omin[2]};
            float p[3];
            rd_mat4_transform_point(w, q, p);
            if (rd_vec3_isfinite(p)) grow_box(bmin, bmax, p);
        }
    }
    if (!(bmin[0] <= bmax[0])) {
        /* nothing finite: a unit box centred at the origin */
        rd_vec3_set(bmin, -0.5f, -0.5f, -0.5f);
        rd_vec3_set(bmax, 0.5f, 0.5f, 0.5f);
    }
    memcpy(s->bounds_min, bmin, sizeof bmin);
    memcpy(s->bounds_max, bmax, sizeof bmax);
}

bool rd_scene_update(rd_scene *s, char *err, size_t errlen)
{
    if (err && errlen > 0) err[0] = '\0';
    if (!update_world(s, err, errlen)) return false;
    for (uint32_t i = 0; i < s->light_count; i++) {
        int32_t n = s->lights[i].node;
        if (n < -1 || (n >= 0 && (uint32_t)n >= s->node_count))
            return fail(err, errlen, "light %u is placed by node %d, but there are only %u nodes",
                        i, (int)n, s->node_count);
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        int32_t n = s->cameras[i].node;
        if (n < -1 || (n >= 0 && (uint32_t)n >= s->node_count))
            return fail(err, errlen, "camera %u is placed by node %d, but there are only %u nodes",
                        i, (int)n, s->node_count);
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        rd_light *l = &s->lights[i];
        if (l->node >= 0) place(&s->nodes[l->node], l->position, l->direction, NULL);
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        rd_camera *c = &s->cameras[i];
        if (c->node >= 0) place(&s->nodes[c->node], c->position, c->forward, c->up);
    }

    uint32_t count = 0;
    for (uint32_t i = 0; i < s->node_count; i++)
        count += s->nodes[i].mesh >= 0;
    free(s->instances);
    s->instances = xcalloc(count, sizeof *s->instances);
    s->instance_count = count;
    count = 0;
    for (uint32_t i = 0; i < s->node_count; i++) {
        if (s->nodes[i].mesh >= 0) {
            s->instances[count].node = i;
            s->instances[count].mesh = (uint32_t)s->nodes[i].mesh;
            count++;
        }
    }
    rd_scene_deform(s);
    update_bounds(s);
    return true;
}
