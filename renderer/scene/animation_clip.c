/* animation_clip.c: glTF 2.0 node animation sampling (see animation_clip.h).
 *
 * Interpolation follows the glTF 2.0 specification, section 3.11 and appendix C: LINEAR lerps
 * vectors and slerps quaternions (shortest arc), STEP holds the key at or before t,
 * CUBICSPLINE is the cubic Hermite spline whose tangents are scaled by the key interval.
 * Arithmetic is in double; results are checked before they reach a node.
 */
#include "renderer/scene/animation_clip.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Largest i with times[i] <= t, for times[0] <= t < times[n - 1] (times non-decreasing). */
static uint32_t key_before(const float *times, uint32_t n, double t)
{
    uint32_t lo = 0, hi = n - 1; /* times[lo] <= t < times[hi] */
    while (hi - lo > 1) {
        uint32_t mid = lo + (hi - lo) / 2;
        if ((double)times[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* q / |q| in double; false (q untouched) when |q| is zero or not finite. */
static bool quat_normalize(double q[4])
{
    double len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(len > 0.0) || !isfinite(len)) return false;
    for (int k = 0; k < 4; k++)
        q[k] /= len;
    return true;
}

static void quat_load(const float *src, double q[4])
{
    for (int k = 0; k < 4; k++)
        q[k] = src[k];
    if (!quat_normalize(q)) q[0] = q[1] = q[2] = 0.0, q[3] = 1.0;
}

/* Spherical linear interpolation along the shorter arc; nearly equal rotations use a
 * normalised lerp (sin(theta) would be ~0). */
static void slerp(const float *a, const float *b, double u, double out[4])
{
    double qa[4], qb[4];
    quat_load(a, qa);
    quat_load(b, qb);
    double d = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3];
    if (d < 0.0) {
        for (int k = 0; k < 4; k++)
            qb[k] = -qb[k];
        d = -d;
    }
    double wa = 1.0 - u, wb = u;
    if (d < 0.9995) {
        double theta = acos(d), s = sin(theta);
        wa = sin((1.0 - u) * theta) / s;
        wb = sin(u * theta) / s;
    }
    for (int k = 0; k < 4; k++)
        out[k] = wa * qa[k] + wb * qb[k];
}

/* Checks a sample and writes it as floats. A rotation is normalised first; a degenerate one
 * becomes the identity when identity_ok, else the sample is refused. */
static bool finish(double *r, uint32_t c, bool rotation, bool identity_ok, float *out)
{
    if (rotation && !quat_normalize(r)) {
        if (!identity_ok) return false;
        r[0] = r[1] = r[2] = 0.0, r[3] = 1.0;
    }
    for (uint32_t k = 0; k < c; k++)
        if (!isfinite(r[k]) || fabs(r[k]) > FLT_MAX) return false;
    for (uint32_t k = 0; k < c; k++)
        out[k] = (float)r[k];
    return true;
}

bool rd_anim_sampler_eval(const rd_anim_sampler *sm, bool rotation, double t, float *out)
{
    uint32_t c = sm->components, n = sm->key_count;
    if (n == 0 || c < 1 || c > RD_ANIM_MAX_COMPONENTS || !sm->times || !sm->values) return false;
    rotation = rotation && c == 4;
    bool cubic = sm->interpolation == RD_INTERP_CUBICSPLINE;
    size_t stride = (size_t)c * (cubic ? 3 : 1), voff = cubic ? c : 0;
    const float *key; /* the key value at or before t (the result, or the fallback) */
    double r[RD_ANIM_MAX_COMPONENTS] = {0};
    bool interpolated = false;
    if (n == 1 || !(t >= (double)sm->times[0])) {
        key = sm->values + voff;
    } else if (t >= (double)sm->times[n - 1]) {
        key = sm->values + (size_t)(n - 1) * stride + voff;
    } else {
        uint32_t i = key_before(sm->times, n, t);
        double dt = (double)sm->times[i + 1] - (double)sm->times[i];
        double u = dt > 0.0 ? (t - (double)sm->times[i]) / dt : 0.0;
        u = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
        const float *a = sm->values + (size_t)i * stride + voff;
        const float *b = sm->values + (size_t)(i + 1) * stride + voff;
        key = a;
        if (sm->interpolation == RD_INTERP_LINEAR && rotation) {
            slerp(a, b, u, r);
            interpolated = true;
        } else if (sm->interpolation == RD_INTERP_LINEAR) {
            for (uint32_t k = 0; k < c; k++)
                r[k] = (double)a[k] + ((double)b[k] - (double)a[k]) * u;
            interpolated = true;
        } else if (cubic) {
            const float *out_tangent = a + c; /* b_i */
            const float *in_tangent = b - c;  /* a_(i+1) */
            double u2 = u * u, u3 = u2 * u;
            double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u;
            double h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
            for (uint32_t k = 0; k < c; k++)
                r[k] =
                    h00 * a[k] + dt * h10 * out_tangent[k] + h01 * b[k] + dt * h11 * in_tangent[k];
            interpolated = true;
        } /* STEP: the key at or before t */
    }
    if (interpolated && finish(r, c, rotation, false, out)) return true;
    for (uint32_t k = 0; k < c; k++)
        r[k] = key[k];
    return finish(r, c, rotation, true, out);
}

/* Local time of an animation of duration d at global time t (see rd_scene_animate). */
static double loop_time(double t, double d)
{
    if (!isfinite(t) || !(d > 0.0) || !isfinite(d)) return 0.0;
    double local = fmod(t, d);
    if (local < 0.0) local += d;
    return local < d ? local : 0.0; /* -tiny + d may round to d */
}

void rd_scene_animate(rd_scene *s, double t)
{
    for (uint32_t ai = 0; ai < s->animation_count; ai++) {
        const rd_animation *a = &s->animations[ai];
        double local = loop_time(t, a->duration);
        for (uint32_t ci = 0; ci < a->channel_count; ci++) {
            const rd_anim_channel *ch = &a->channels[ci];
            if (ch->node >= s->node_count || ch->sampler >= a->sampler_count) continue;
            const rd_anim_sampler *sm = &a->samplers[ch->sampler];
            rd_node *n = &s->nodes[ch->node];
            float v[4];
            if (ch->path == RD_ANIM_ROTATION) {
                if (sm->components == 4 && rd_anim_sampler_eval(sm, true, local, v))
                    memcpy(n->rotation, v, sizeof n->rotation);
            } else if (ch->path == RD_ANIM_TRANSLATION || ch->path == RD_ANIM_SCALE) {
                if (sm->components == 3 && rd_anim_sampler_eval(sm, false, local, v))
                    memcpy(ch->path == RD_ANIM_SCALE ? n->scale : n->translation, v,
                           3 * sizeof(float));
            } else if (ch->path == RD_ANIM_WEIGHTS && n->weights &&
                       sm->components == n->weight_count) {
                rd_anim_sampler_eval(sm, false, local, n->weights); /* all or nothing */
            }
        }
    }
}

double rd_scene_animation_duration(const rd_scene *s)
{
    double d = 0.0;
    for (uint32_t i = 0; i < s->animation_count; i++)
        if (s->animations[i].duration > d) d = s->animations[i].duration;
    return d;
}

void rd_scene_animated_nodes(const rd_scene *s, bool *out)
{
    uint32_t n = s->node_count;
    if (n == 0) return;
    /* 0 = unknown, 1 = moves, 2 = still, 3 = on the chain being walked */
    uint8_t *state = calloc(n, 1);
    uint32_t *chain = malloc((size_t)n * sizeof *chain);
    if (!state || !chain) {
        fprintf(stderr, "probecast: out of memory (%u nodes)\n", n);
        abort();
    }
    for (uint32_t ai = 0; ai < s->animation_count; ai++)
        for (uint32_t ci = 0; ci < s->animations[ai].channel_count; ci++) {
            const rd_anim_channel *ch = &s->animations[ai].channels[ci];
            if (ch->node < n && ch->path != RD_ANIM_WEIGHTS) state[ch->node] = 1;
        }
    for (uint32_t i = 0; i < n; i++) {
        /* walk up to a node whose state is known; a root, a broken parent index or a cycle
         * (rd_scene_update rejects both) counts as still */
        uint32_t len = 0;
        int64_t j = i;
        while (j >= 0 && j < n && state[j] == 0) {
            state[j] = 3;
            chain[len++] = (uint32_t)j;
            j = s->nodes[j].parent;
        }
        uint8_t v = j >= 0 && j < n && state[j] == 1 ? 1 : 2;
        while (len > 0)
            state[chain[--len]] = v;
        out[i] = state[i] == 1;
    }
    free(state);
    free(chain);
}
