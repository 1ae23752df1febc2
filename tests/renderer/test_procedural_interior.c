/* test_procedural_interior.c: builtin:interior[:M] (renderer/builtin/procedural_interior.c) on the CPU.
 *
 * Checks that the triangle count follows M, that the scene lies inside the building's slabs,
 * that it has lights and cameras inside, and that every room is closed except for its openings:
 * rays from a room's centre against the building mesh (walls, floor, ceiling) all hit within
 * the room at 2.6 m (above every door and window), some escape at 1.5 m (through the door and
 * the windows), and straight up and down they meet the ceiling and the floor. */
#include "renderer/accel/bvh.h"
#include "renderer/builtin/procedural.h"
#include "renderer/builtin/procedural_interior.h"
#include "test_util.h"

#include <math.h>
#include <string.h>

#define DIRS 256

static const rd_mesh *building_mesh(const rd_scene *s)
{
    for (uint32_t i = 0; i < s->mesh_count; i++)
        if (strcmp(s->meshes[i].name, "building") == 0) return &s->meshes[i];
    return NULL;
}

/* Closest hit distance of the ray against mesh m (object = world: the building is not moved),
 * or INFINITY. */
static float closest(const rd_mesh *m, const float o[3], const float d[3])
{
    float best = INFINITY;
    for (uint32_t i = 0; i < m->tri_count; i++) {
        const float *p = &m->positions[9 * i];
        float t, u, v;
        bool back;
        if (rd_ray_triangle(o, d, p, p + 3, p + 6, 0.0f, best, &t, &u, &v, &back)) best = t;
    }
    return best;
}

/* Distance from o along the horizontal unit direction d to the room box's side (o inside). */
static float to_box(const float lo[3], const float hi[3], const float o[3], const float d[3])
{
    float t = INFINITY;
    for (int k = 0; k < 3; k += 2) {
        if (d[k] > 0) t = fminf(t, (hi[k] - o[k]) / d[k]);
        if (d[k] < 0) t = fminf(t, (lo[k] - o[k]) / d[k]);
    }
    return t;
}

static void check_rooms(const rd_scene *s)
{
    const rd_mesh *b = building_mesh(s);
    CHECK(b != NULL);
    if (!b) return;
    for (unsigned r = 0; r < RD_INTERIOR_ROOMS; r++) {
        float lo[3], hi[3];
        rd_interior_room_bounds(r, lo, hi);
        CHECK(hi[0] - lo[0] > 3 && hi[2] - lo[2] > 3 && hi[1] > 2.5f);
        unsigned closed_high = 0, escaped_low = 0;
        for (unsigned i = 0; i < DIRS; i++) {
            float a = 2.0f * (float)M_PI * (i + 0.5f) / DIRS;
            const float d[3] = {cosf(a), 0, sinf(a)};
            float o[3] = {(lo[0] + hi[0]) / 2, 2.6f, (lo[2] + hi[2]) / 2};
            float wall = to_box(lo, hi, o, d);
            float t = closest(b, o, d);
            if (fabsf(t - wall) < 1e-3f) closed_high++;
            o[1] = 1.5f;
            t = closest(b, o, d);
            if (t > wall + 0.2f) escaped_low++;
        }
        CHECKF(closed_high == DIRS, "room %u: %u of %d rays at 2.6 m meet its walls", r,
               closed_high, DIRS);
        CHECKF(escaped_low > 0 && escaped_low < DIRS / 4,
               "room %u: %u of %d rays at 1.5 m leave through openings", r, escaped_low, DIRS);
        const float o[3] = {(lo[0] + hi[0]) / 2, 1.5f, (lo[2] + hi[2]) / 2};
        const float up[3] = {0, 1, 0}, down[3] = {0, -1, 0};
        CHECK(fabsf(closest(b, o, up) - (hi[1] - 1.5f)) < 1e-4f);
        CHECK(fabsf(closest(b, o, down) - 1.5f) < 1e-4f);
    }
}

static void check_scene(double millions, rd_scene *s)
{
    char err[256] = "", name[64];
    snprintf(name, sizeof name, "interior:%g", millions);
    CHECKF(rd_procedural_build(name, s, err, sizeof err), "%s: %s", name, err);
    double tris = (double)s->tri_total;
    CHECKF(fabs(tris / (millions * 1e6) - 1) < 0.15, "%s: %.0f triangles", name, tris);
    /* everything inside the building: slabs 0.1 m, walls 0.12 m thick */
    CHECK(s->bounds_min[0] >= -10.07f && s->bounds_max[0] <= 10.07f);
    CHECK(s->bounds_min[2] >= -6.07f && s->bounds_max[2] <= 6.07f);
    CHECK(s->bounds_min[1] >= -0.11f && s->bounds_max[1] <= 3.11f);
    CHECK(s->bounds_max[0] - s->bounds_min[0] > 20 && s->bounds_max[1] - s->bounds_min[1] > 3);
    CHECK(s->instance_count > 8 * RD_INTERIOR_ROOMS); /* furniture is instanced */
    CHECK(s->instance_count < s->node_count + 1 && s->mesh_count < s->instance_count / 4);
    CHECK(s->light_count >= RD_INTERIOR_ROOMS + 1 && s->camera_count >= 1);
    unsigned point = 0, sun = 0;
    for (uint32_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        if (l->type == RD_LIGHT_DIRECTIONAL) sun++;
        if (l->type != RD_LIGHT_POINT) continue;
        point++;
        CHECK(l->position[0] > -10 && l->position[0] < 10 && l->position[1] > 0 &&
              l->position[1] < 3 && l->position[2] > -6 && l->position[2] < 6);
    }
    CHECK(point >= RD_INTERIOR_ROOMS && sun == 1);
    const float *eye = s->cameras[0].position;
    CHECK(eye[0] > -10 && eye[0] < 10 && eye[1] > 0 && eye[1] < 3 && eye[2] > -6 && eye[2] < 6);
}

int main(void)
{
    rd_scene a, b;
    check_scene(0.2, &a);
    check_scene(0.8, &b);
    CHECKF(test_close_rel((double)b.tri_total / (double)a.tri_total, 4.0, 0.2), "%llu vs %llu",
           (unsigned long long)b.tri_total, (unsigned long long)a.tri_total);
    /* the same M gives the same scene */
    rd_scene c;
    char err[256];
    CHECK(rd_procedural_build("interior:0.2", &c, err, sizeof err));
    CHECK(c.tri_total == a.tri_total && c.mesh_count == a.mesh_count);
    CHECK(c.mesh_count == a.mesh_count &&
          memcmp(c.meshes[c.mesh_count - 1].positions, a.meshes[a.mesh_count - 1].positions,
                 9 * sizeof(float) * a.meshes[a.mesh_count - 1].tri_count) == 0);
    rd_scene_destroy(&c);
    check_rooms(&a);
    CHECK(!rd_procedural_build("interior:0", &c, err, sizeof err));
    CHECK(!rd_procedural_build("interior:abc", &c, err, sizeof err));
    rd_scene_destroy(&a);
    rd_scene_destroy(&b);
    rd_scene_destroy(&c);
    return test_finish();
}
