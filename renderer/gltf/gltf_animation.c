/* gltf_animation.c: a glTF document's node animations — channels, samplers and their keys,
 * read and checked (glTF 2.0 section 3.11; see gltf_import.h and gltf_document.h): translation,
 * rotation, scale and morph target weights. Channels that animate an extension's target, or the
 * weights of a node without morph targets, are skipped with one warning; so are nodes outside the
 * scene shown. */
#include "renderer/gltf/gltf_document.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

rd_gltf_result rd_gltf_read_keys(const char *where, const rd_gltf_accessor *in,
                                 const rd_gltf_accessor *val, uint32_t components, float *times,
                                 float *values, char *err, size_t errlen)
{
    for (size_t i = 0; i < in->count; i++) {
        float *t = &times[i];
        rd_gltf_read_floats(in, i, t);
        if (!isfinite(*t) || *t < 0.0f || (i > 0 && *t < t[-1]))
            return rd_gltf_fail(
                err, errlen, RD_GLTF_ERR_INVALID,
                "%s has input time %g at key %zu; times must be finite, >= 0 and not decrease",
                where, (double)*t, i);
    }
    for (size_t i = 0; i < val->count; i++) {
        float *v = &values[i * components];
        rd_gltf_read_floats(val, i, v);
        for (uint32_t k = 0; k < components; k++)
            if (!isfinite(v[k]))
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "%s has an output value that is NaN or infinite (%zu)", where,
                                    i);
    }
    return RD_GLTF_OK;
}

/* ---- a document's animations ----------------------------------------------------------------- */

static const uint64_t kMaxAnimationFloats = 1ull << 26; /* 256 MiB of animation keys and values */

static bool str_is(rd_gltf_str s, const char *lit)
{
    return s.len == strlen(lit) && memcmp(s.s, lit, s.len) == 0;
}

static uint32_t interpolation(rd_gltf_str ip)
{
    return str_is(ip, "LINEAR")        ? (uint32_t)RD_INTERP_LINEAR
           : str_is(ip, "STEP")        ? (uint32_t)RD_INTERP_STEP
           : str_is(ip, "CUBICSPLINE") ? (uint32_t)RD_INTERP_CUBICSPLINE
                                       : UINT32_MAX;
}

/* Validates an animation sampler for a translation/scale (VEC3 float), rotation (VEC4 float or
 * normalized integers) or weights (SCALAR float or normalized integers, `targets` values per
 * key) channel and reads its keys into out (times and values malloc'd) (glTF 2.0 section 3.11). */
static rd_gltf_result anim_sampler(rd_gltf_conv *c, const char *where,
                                   const rd_gltf_doc_anim_sampler *gs, uint32_t path,
                                   uint32_t targets, rd_anim_sampler *out)
{
    static const int f[] = {RD_GLTF_FLOAT};
    static const int rot[] = {RD_GLTF_FLOAT, RD_GLTF_BYTE, RD_GLTF_UNSIGNED_BYTE, RD_GLTF_SHORT,
                              RD_GLTF_UNSIGNED_SHORT};
    bool rotation = path == RD_ANIM_ROTATION, weights = path == RD_ANIM_WEIGHTS;
    char *err = c->err, what[300];
    size_t errlen = c->errlen;
    out->interpolation = interpolation(gs->interpolation);
    if (out->interpolation == UINT32_MAX) {
        char ip[128];
        rd_gltf_clean(gs->interpolation.s, gs->interpolation.len, 32, ip);
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "%s has an unknown interpolation '%s'", where, ip);
    }
    rd_gltf_accessor in, val;
    memset(&val, 0, sizeof val);
    snprintf(what, sizeof what, "input of %s", where);
    rd_gltf_result r = rd_gltf_resolve_accessor(c->doc, gs->input, what, RD_GLTF_TYPE_SCALAR, f, 1,
                                                &in, err, errlen);
    if (r != RD_GLTF_OK) return r;
    snprintf(what, sizeof what, "output of %s", where);
    if (rotation)
        r = rd_gltf_resolve_accessor(c->doc, gs->output, what, RD_GLTF_TYPE_VEC4, rot, 5, &val, err,
                                     errlen);
    else if (weights)
        r = rd_gltf_resolve_accessor(c->doc, gs->output, what, RD_GLTF_TYPE_SCALAR, rot, 5, &val,
                                     err, errlen);
    else
        r = rd_gltf_resolve_accessor(c->doc, gs->output, what, RD_GLTF_TYPE_VEC3, f, 1, &val, err,
                                     errlen);
    if (r == RD_GLTF_OK && weights && val.ctype != RD_GLTF_FLOAT && !val.normalized)
        r = rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                         "accessor %d (%s) holds integers but is not normalized", gs->output, what);
    /* weights: one scalar per target and key, read as keys of `targets` components */
    size_t keys = in.count, per_key = (out->interpolation == RD_INTERP_CUBICSPLINE ? 3 : 1) *
                                      (weights ? (size_t)targets : 1);
    if (r == RD_GLTF_OK && (val.count / per_key != keys || val.count % per_key != 0))
        r = rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                         "%s has %zu output values for %zu input times (%s needs %zu)", where,
                         val.count, keys, gs->interpolation.s, keys * per_key);
    out->components = rotation ? 4 : weights ? targets : 3;
    if (r == RD_GLTF_OK) {
        if (val.count <= kMaxAnimationFloats)
            c->anim_floats += keys + val.count * (weights ? 1 : out->components);
        if (val.count > kMaxAnimationFloats || c->anim_floats > kMaxAnimationFloats)
            r = rd_gltf_fail(err, errlen, RD_GLTF_ERR_TOO_LARGE,
                             "the animations hold more than %llu keys and values (the limit)",
                             (unsigned long long)kMaxAnimationFloats);
    }
    if (r == RD_GLTF_OK) {
        out->key_count = (uint32_t)keys;
        out->times = rd_gltf_alloc(keys, sizeof(float));
        out->values = rd_gltf_alloc(val.count * (weights ? 1 : out->components), sizeof(float));
        r = rd_gltf_read_keys(where, &in, &val, weights ? 1 : out->components, out->times,
                              out->values, err, errlen);
    }
    rd_gltf_accessor_dispose(&in);
    rd_gltf_accessor_dispose(&val);
    return r;
}

/* The latest input time of the samplers any channel uses, skipped channels too (as viewers
 * that play them do). */
static rd_gltf_result duration(rd_gltf_conv *c, const rd_gltf_doc_animation *ga, const char *an,
                               const uint8_t *used, float *out)
{
    static const int f[] = {RD_GLTF_FLOAT};
    for (size_t si = 0; si < ga->sampler_count; si++) {
        if (!used[si]) continue;
        char what[300];
        snprintf(what, sizeof what, "input of %s sampler %zu", an, si);
        rd_gltf_accessor in;
        rd_gltf_result r =
            rd_gltf_resolve_accessor(c->doc, ga->samplers[si].input, what, RD_GLTF_TYPE_SCALAR, f,
                                     1, &in, c->err, c->errlen);
        if (r != RD_GLTF_OK) return r;
        float last;
        rd_gltf_read_floats(&in, in.count - 1, &last);
        rd_gltf_accessor_dispose(&in);
        if (isfinite(last) && last > *out) *out = last;
    }
    return RD_GLTF_OK;
}

/* One animation's channels and samplers; target[node * 4 + path] is SIZE_MAX on entry and left
 * so. */
static rd_gltf_result animation(rd_gltf_conv *c, size_t ai, size_t *target, size_t *skipped_weights,
                                size_t *skipped_other)
{
    const rd_gltf_document *d = c->doc;
    const rd_gltf_doc_animation *ga = &d->animations[ai];
    char an[RD_GLTF_LABEL_MAX], where[RD_GLTF_LABEL_MAX + 32], sw[RD_GLTF_LABEL_MAX + 32];
    rd_gltf_label("animation", ai, ga->name, an);
    size_t ns = ga->sampler_count, nc = ga->channel_count, kept_n = 0, channel_n = 0;
    uint32_t *kept = rd_gltf_alloc(ns * 4, sizeof *kept); /* (sampler, path) -> kept sampler */
    uint8_t *used = rd_gltf_alloc(ns, 1);                 /* by any channel, even skipped */
    rd_anim_sampler *samplers = rd_gltf_alloc(nc, sizeof *samplers);
    rd_anim_channel *channels = rd_gltf_alloc(nc, sizeof *channels);
    size_t *touched = rd_gltf_alloc(nc, sizeof *touched), touched_n = 0;
    memset(kept, 0xff, ns * 4 * sizeof *kept);
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t ci = 0; ci < nc && r == RD_GLTF_OK; ci++) {
        const rd_gltf_doc_channel *gc = &ga->channels[ci];
        snprintf(where, sizeof where, "%s channel %zu", an, ci);
        int node = gc->node;
        if (gc->sampler < 0 || (size_t)gc->sampler >= ns) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s refers to sampler %d, but %s has only %zu samplers", where,
                             gc->sampler, an, ns);
            break;
        }
        if (node < -1 || (node >= 0 && (size_t)node >= d->node_count)) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s targets node %d, but there are only %zu nodes", where, node,
                             d->node_count);
            break;
        }
        used[gc->sampler] = 1;
        uint32_t p = str_is(gc->path, "translation") ? (uint32_t)RD_ANIM_TRANSLATION
                     : str_is(gc->path, "rotation")  ? (uint32_t)RD_ANIM_ROTATION
                     : str_is(gc->path, "scale")     ? (uint32_t)RD_ANIM_SCALE
                     : str_is(gc->path, "weights")   ? (uint32_t)RD_ANIM_WEIGHTS
                                                     : UINT32_MAX;
        if (gc->path.len == 0) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID, "%s has no target path",
                             where);
            break;
        }
        *skipped_other += p == UINT32_MAX;
        if (p == UINT32_MAX || node < 0) continue; /* no node: ignored, as the spec says */
        if (p != RD_ANIM_WEIGHTS && d->nodes[node].transform.matrix_count != 0) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s animates node %d, which has a matrix; glTF allows animating only "
                             "nodes given by translation, rotation and scale",
                             where, node);
            break;
        }
        size_t *t = &target[(size_t)node * 4 + p];
        if (*t != SIZE_MAX) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s animates the %s of node %d, as channel %zu does", where,
                             gc->path.s, node, *t);
            break;
        }
        *t = ci;
        touched[touched_n++] = (size_t)node * 4 + p;
        if (c->node_map[node] < 0) continue; /* not in the scene shown */
        uint32_t targets = c->s->nodes[c->node_map[node]].weight_count;
        if (p == RD_ANIM_WEIGHTS && targets == 0) {
            (*skipped_weights)++; /* a node without morph targets */
            continue;
        }
        uint32_t *k = &kept[(size_t)gc->sampler * 4 + p];
        if (*k == UINT32_MAX) {
            *k = (uint32_t)kept_n++;
            snprintf(sw, sizeof sw, "%s sampler %d", an, gc->sampler);
            r = anim_sampler(c, sw, &ga->samplers[gc->sampler], p, targets, &samplers[*k]);
            if (r != RD_GLTF_OK) break;
        } else if (p == RD_ANIM_WEIGHTS && samplers[*k].components != targets) {
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "%s animates the %u morph weights of node %d with sampler %d, which "
                             "another channel uses for %u weights",
                             where, targets, node, gc->sampler, samplers[*k].components);
            break;
        }
        channels[channel_n++] = (rd_anim_channel){(uint32_t)c->node_map[node], p, *k};
    }
    if (r == RD_GLTF_OK && channel_n > 0) {
        rd_animation a;
        memset(&a, 0, sizeof a);
        r = duration(c, ga, an, used, &a.duration);
        a.name = ga->name.len ? (char *)ga->name.s : NULL;
        a.samplers = samplers;
        a.sampler_count = (uint32_t)kept_n;
        a.channels = channels;
        a.channel_count = (uint32_t)channel_n;
        if (r == RD_GLTF_OK) rd_scene_add_animation(c->s, &a);
    }
    for (size_t i = 0; i < touched_n; i++)
        target[touched[i]] = SIZE_MAX;
    for (size_t i = 0; i < kept_n; i++) {
        free(samplers[i].times);
        free(samplers[i].values);
    }
    free(kept);
    free(used);
    free(samplers);
    free(channels);
    free(touched);
    return r;
}

rd_gltf_result rd_gltf_conv_animations(rd_gltf_conv *c)
{
    size_t skipped_weights = 0, skipped_other = 0, n = c->doc->node_count * 4;
    size_t *target = rd_gltf_alloc(n, sizeof *target); /* (node, path) -> channel */
    for (size_t i = 0; i < n; i++)
        target[i] = SIZE_MAX;
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t ai = 0; ai < c->doc->animation_count && r == RD_GLTF_OK; ai++)
        r = animation(c, ai, target, &skipped_weights, &skipped_other);
    free(target);
    if (r != RD_GLTF_OK) return r;
    if (skipped_weights)
        rd_scene_warn(c->s,
                      "%zu animation channel(s) animate the morph weights of a node whose mesh "
                      "has no morph targets; they are ignored",
                      skipped_weights);
    if (skipped_other)
        rd_scene_warn(c->s,
                      "%zu animation channel(s) have an unknown target path; they are ignored",
                      skipped_other);
    return RD_GLTF_OK;
}
