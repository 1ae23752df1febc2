/* Strict parsing of API bodies, and patches applied to the scene state (plain CPU code: no
 * daemon, no GPU; the stream's viewer messages: test_viewer_msg.c). */
#include <math.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/scene/scene_state.h"
#include "renderer/scene/mesh_builder.h"
#include "test_util.h"

static bool parse_camera(const char *text, srv_camera_patch *p, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_camera_patch(j, p, e);
    cJSON_Delete(j);
    return ok;
}

static bool parse_light(const char *text, srv_light_patch *p, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_light_patch(j, p, e);
    cJSON_Delete(j);
    return ok;
}

static bool parse_settings(const char *text, srv_settings_patch *p, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_settings_patch(j, p, e);
    cJSON_Delete(j);
    return ok;
}

/* Parses text with one of the patch parsers; on failure, *message holds the 400's message. */
typedef bool (*patch_parser)(const cJSON *, void *, srv_api_error *);

static bool parse_with(patch_parser f, const char *text, void *out, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = f(j, out, e);
    cJSON_Delete(j);
    return ok;
}

static bool node_parser(const cJSON *j, void *p, srv_api_error *e)
{
    return srv_json_node_patch(j, p, e);
}
static bool playback_parser(const cJSON *j, void *p, srv_api_error *e)
{
    return srv_json_playback_patch(j, p, e);
}
static bool pick_parser(const cJSON *j, void *p, srv_api_error *e)
{
    return srv_json_pick_request(j, p, e);
}

/* The failure's message is exactly want (the bodies share one table-driven parser; each keeps
 * its own sentences). */
static void check_rejects(patch_parser f, const char *text, const char *want)
{
    srv_api_error e = {0};
    char out[256];
    CHECKF(!parse_with(f, text, out, &e), "'%s' was accepted", text);
    CHECKF(e.status == 400 && strcmp(e.message, want) == 0, "'%s' -> %d '%s', want '%s'", text,
           e.status, e.message, want);
}

static void test_patch_shapes(void)
{
    srv_node_patch np;
    srv_api_error e;
    CHECK(parse_with(node_parser, "{\"translation\":[1,2,3],\"scale\":[2,2,2]}", &np, &e));
    CHECK(np.has == (SRV_NODE_TRANSLATION | SRV_NODE_SCALE) && np.translation[2] == 3 &&
          np.scale[0] == 2);
    check_rejects(node_parser, "{\"scale\":[1,0,1]}",
                  "Field 'scale' must not have zero components.");
    check_rejects(node_parser, "{\"rotation\":[0,0,0,0]}",
                  "Field 'rotation' must be a non-zero quaternion.");
    check_rejects(node_parser, "{\"translation\":[1,2]}",
                  "Field 'translation' must be an array of 3 numbers.");
    check_rejects(node_parser, "{\"translation\":[1,2,3],\"translation\":[1,2,3]}",
                  "Field 'translation' appears more than once.");
    check_rejects(node_parser, "{\"matrix\":[]}",
                  "Unknown node field 'matrix' (translation, rotation and scale can be changed).");
    check_rejects(node_parser, "{}", "Give at least one of 'translation', 'rotation' and 'scale'.");

    srv_playback_patch pp;
    CHECK(parse_with(playback_parser, "{\"playing\":false,\"time\":2.5}", &pp, &e));
    CHECK(pp.has == (SRV_PLAY_PLAYING | SRV_PLAY_TIME) && !pp.playing && pp.time_s == 2.5);
    check_rejects(playback_parser, "{\"playing\":1}", "Field 'playing' must be true or false.");
    check_rejects(playback_parser, "{\"time\":-1}",
                  "Field 'time' must be a finite number of seconds, 0 or more.");
    check_rejects(playback_parser, "{\"speed\":2}",
                  "Unknown animation field 'speed' (playing and time can be changed).");

    float point[2];
    CHECK(parse_with(pick_parser, "{\"x\":0.25,\"y\":0.75}", point, &e));
    CHECK(point[0] == 0.25f && point[1] == 0.75f);
    check_rejects(pick_parser, "{\"x\":0.5}",
                  "Give both 'x' and 'y': the point in the picture, 0..1 across and down.");
    check_rejects(pick_parser, "{\"x\":1.5,\"y\":0}", "Field 'x' must be a number in [0, 1].");
}

static void test_bodies(void)
{
    srv_api_error e;
    srv_camera_patch cp;
    /* malformed JSON and non-objects */
    const char *malformed[] = {"", "{", "[1,2]", "42", "{\"a\":1} x", "{\"a\":}", "nul"};
    for (size_t i = 0; i < sizeof malformed / sizeof *malformed; i++) {
        CHECKF(!parse_camera(malformed[i], &cp, &e), "'%s'", malformed[i]);
        CHECKF(e.status == 400 && strcmp(e.code, SRV_ERR_MALFORMED_JSON) == 0, "'%s' -> %s",
               malformed[i], e.code);
    }
    /* wrong types, ranges, unknown and duplicate fields */
    const char *invalid[] = {
        "{\"position\":\"x\"}",
        "{\"position\":[1,2]}",
        "{\"position\":[1,2,\"3\"]}",
        "{\"fov\":0}",
        "{\"fov\":200}",
        "{\"fov\":\"40\"}",
        "{\"up\":[0,0,0]}",
        "{\"zoom\":1}",
        "{\"position\":[1e999,0,0]}",
        "{\"target\":[0,0,0],\"forward\":[0,0,1]}",
        "{\"orientation\":[0,0,0,1],\"up\":[0,1,0]}",
        "{\"fov\":40,\"fov\":50}",
        "{\"orientation\":[0,0,0,0]}",
    };
    for (size_t i = 0; i < sizeof invalid / sizeof *invalid; i++) {
        CHECKF(!parse_camera(invalid[i], &cp, &e), "'%s' was accepted", invalid[i]);
        CHECKF(e.status == 400 && strcmp(e.code, SRV_ERR_INVALID_FIELD) == 0, "'%s' -> %s",
               invalid[i], e.code);
    }
    CHECK(parse_camera("{\"position\":[0,1,5],\"target\":[0,1,0],\"fov\":45}", &cp, &e));
    CHECK(cp.has == (SRV_CAM_POSITION | SRV_CAM_TARGET | SRV_CAM_FOV) && cp.fov_deg == 45);

    srv_light_patch lp;
    CHECK(parse_light("{\"type\":\"spot\",\"color\":[1,0.5,0],\"intensity\":10,\"range\":null}",
                      &lp, &e));
    CHECK(lp.type == RD_LIGHT_SPOT && lp.range == 0 && lp.color[1] == 0.5f);
    CHECK(!parse_light("{\"type\":\"area\"}", &lp, &e) && e.status == 400);
    CHECK(!parse_light("{\"intensity\":-1}", &lp, &e));
    CHECK(!parse_light("{\"id\":3}", &lp, &e));
    CHECK(!parse_light("{\"direction\":[0,0,0]}", &lp, &e));
    CHECK(!parse_light("{\"name\":5}", &lp, &e));
    CHECK(!parse_light("{\"node\":1}", &lp, &e) &&
          strcmp(e.message, "Field 'node' is read-only.") == 0);
    CHECK(!parse_light("{\"glow\":1}", &lp, &e) &&
          strcmp(e.message, "Unknown light field 'glow'.") == 0);
    CHECK(parse_light("{\"range\":4,\"name\":\"key\"}", &lp, &e) && lp.range == 4 &&
          strcmp(lp.name, "key") == 0 && lp.has == (SRV_LIGHT_RANGE | SRV_LIGHT_NAME));

    srv_settings_patch sp;
    CHECK(parse_settings("{\"width\":64,\"height\":48,\"gi_mode\":\"off\",\"probe_counts\":[2,2,2],"
                         "\"animate\":false}",
                         &sp, &e));
    CHECK(sp.v.width == 64 && sp.v.gi_mode == 0 && sp.v.probe_counts[2] == 2);
    CHECK(!parse_settings("{\"width\":64.5}", &sp, &e));
    CHECK(!parse_settings("{\"width\":8}", &sp, &e));
    CHECK(!parse_settings("{\"probe_counts\":[0,2,2]}", &sp, &e));
    CHECK(!parse_settings("{\"gi_mode\":\"full\"}", &sp, &e));
    CHECK(!parse_settings("{\"animate\":1}", &sp, &e));
    CHECK(!parse_settings("{\"quality_still\":101}", &sp, &e));
}

static void test_state(void)
{
    srv_scene_state st;
    srv_state_init(&st);
    rd_scene s;
    rd_scene_init(&s);
    rd_node n = {
        .name = "box", .parent = -1, .mesh = -1, .rotation = {0, 0, 0, 1}, .scale = {1, 1, 1}};
    rd_scene_add_node(&s, &n);
    rd_light l = {
        .name = "l", .type = RD_LIGHT_POINT, .color = {1, 1, 1}, .intensity = 5, .node = -1};
    rd_scene_add_light(&s, &l);
    char err[128];
    CHECK(rd_scene_update(&s, err, sizeof err));
    srv_state_set_scene(&st, &s, "test", 1);
    CHECK(st.scene.light_count == 1 && st.light_ids[0] == 0);

    srv_api_error e;
    /* camera: target sets the direction; up parallel to it is refused */
    srv_camera_patch cp = {
        .has = SRV_CAM_POSITION | SRV_CAM_TARGET, .position = {0, 0, 5}, .target = {0, 0, 0}};
    CHECK(srv_state_camera_apply(&st.camera, &cp, true, &e));
    CHECK(fabsf(st.camera.forward[2] + 1) < 1e-6f && fabsf(st.camera.target_distance - 5) < 1e-5f);
    srv_camera_patch bad = {.has = SRV_CAM_UP, .up = {0, 0, 1}};
    CHECK(!srv_state_camera_apply(&st.camera, &bad, false, &e));
    srv_camera_patch same = {.has = SRV_CAM_TARGET, .target = {0, 0, 5}};
    CHECK(!srv_state_camera_apply(&st.camera, &same, false, &e));
    srv_camera_patch put = {.has = SRV_CAM_FOV, .fov_deg = 30};
    CHECK(!srv_state_camera_apply(&st.camera, &put, true, &e)); /* PUT needs position + direction */

    /* lights: add, patch (spot cone order checked), delete; ids stay stable */
    srv_light_patch lp = {
        .has = SRV_LIGHT_TYPE | SRV_LIGHT_INTENSITY, .type = RD_LIGHT_SPOT, .intensity = 2};
    uint32_t id = 0;
    CHECK(srv_state_light_add(&st, &lp, &id, &e) && id == 1 && st.scene.light_count == 2);
    srv_light_patch cone = {
        .has = SRV_LIGHT_INNER_CONE | SRV_LIGHT_OUTER_CONE, .inner_cone = 0.5f, .outer_cone = 0.4f};
    CHECK(!srv_state_light_apply(&st.scene.lights[1], &cone, &e));
    CHECK(srv_state_light_delete(&st, 0, &e) && st.scene.light_count == 1);
    CHECK(srv_state_light_index(&st, 1) == 0 && srv_state_light_index(&st, 0) == -1);
    CHECK(!srv_state_light_delete(&st, 0, &e) && e.status == 404);

    /* nodes: moving updates the world matrix; unknown ids are 404 */
    srv_node_patch np = {.has = SRV_NODE_TRANSLATION, .translation = {1, 2, 3}};
    CHECK(srv_state_node_apply(&st, 0, &np, &e) && st.scene.nodes[0].world[13] == 2);
    CHECK(!srv_state_node_apply(&st, 5, &np, &e) && e.status == 404);

    /* settings: whole-or-nothing */
    srv_settings_patch sp = {.has = SRV_SET_WIDTH | SRV_SET_HEIGHT,
                             .v = {.width = 4096, .height = 4096}};
    unsigned w = st.settings.width;
    CHECK(!srv_state_settings_apply(&st.settings, &sp, &e) && st.settings.width == w);

    /* the persisted document restores into a fresh state of the same scene */
    cJSON *doc = srv_state_to_json(&st);
    srv_scene_state st2;
    srv_state_init(&st2);
    rd_scene s2;
    rd_scene_init(&s2);
    rd_scene_add_node(&s2, &n);
    rd_scene_add_light(&s2, &l);
    rd_scene_update(&s2, err, sizeof err);
    srv_state_set_scene(&st2, &s2, "test", 1);
    CHECK(srv_state_restore(&st2, doc, &e));
    CHECK(st2.scene.light_count == 1 && st2.light_ids[0] == 1 &&
          st2.scene.lights[0].type == RD_LIGHT_SPOT);
    CHECK(st2.scene.nodes[0].translation[2] == 3 && fabsf(st2.camera.position[2] - 5) < 1e-5f);
    CHECK(fabsf(st2.camera.target_distance - 5) < 1e-4f);
    cJSON_Delete(doc);
    srv_state_dispose(&st2);
    srv_state_dispose(&st);
}

/* Default lighting: a scene without lights or emission gets a key light (lit from the camera's
 * side) and the default sky; a scene lit by a large emitter does not, one with a small glowing
 * detail does; the saved state keeps which light it is. */
static void test_default_lighting(void)
{
    srv_scene_state st;
    srv_state_init(&st);
    rd_scene s;
    rd_scene_init(&s);
    rd_material m = {.base_color = {1, 1, 1, 1}, .base_color_texture = -1, .emissive_texture = -1};
    rd_scene_add_material(&s, &m);
    srv_state_set_scene(&st, &s, "test", 1);
    CHECK(st.default_lighting && st.scene.light_count == 1);
    const rd_light *key = &st.scene.lights[0];
    CHECK(key->type == RD_LIGHT_DIRECTIONAL && key->intensity > 0);
    /* it shines the way the camera looks, and down */
    float along = key->direction[0] * st.camera.forward[0] +
                  key->direction[1] * st.camera.forward[1] +
                  key->direction[2] * st.camera.forward[2];
    CHECK(along > 0.3f && key->direction[1] < -0.3f);
    rd_environment env;
    srv_state_environment(&st, &env);
    CHECK(env.mode == RD_ENV_UNIFORM && env.sky[0] == RD_DEFAULT_SKY_R &&
          env.sky[2] == RD_DEFAULT_SKY_B);
    CHECK(st.lighting.needed && st.lighting.emitted_w == 0);
    /* an environment set by the user wins */
    st.settings.sky[1] = 0.5f;
    srv_state_environment(&st, &env);
    CHECK(env.sky[0] == 0 && env.sky[1] == 0.5f);
    st.settings.sky[1] = 0;
    st.settings.sky_mode = PC_ENV_GRADIENT;
    st.settings.sky_ground[0] = 0.25f;
    srv_state_environment(&st, &env);
    CHECK(env.mode == RD_ENV_GRADIENT && env.ground[0] == 0.25f && env.sky[0] == 0);
    st.settings.sky_mode = PC_ENV_UNIFORM;
    st.settings.sky_ground[0] = 0;

    /* saved and restored: still default, same light */
    cJSON *doc = srv_state_to_json(&st);
    srv_scene_state st2;
    srv_state_init(&st2);
    rd_scene s2;
    rd_scene_init(&s2);
    rd_scene_add_material(&s2, &m);
    srv_state_set_scene(&st2, &s2, "test", 1);
    srv_api_error e;
    CHECK(srv_state_restore(&st2, doc, &e));
    CHECK(st2.default_lighting && st2.scene.light_count == 1 &&
          st2.default_light_id == st.default_light_id);
    cJSON_Delete(doc);
    /* dropped: the key light goes, the sky is the setting again */
    CHECK(srv_state_drop_default_lighting(&st2) && st2.scene.light_count == 0);
    srv_state_environment(&st2, &env);
    CHECK(env.sky[0] == 0 && env.sky[1] == 0 && env.sky[2] == 0);
    CHECK(!srv_state_drop_default_lighting(&st2));
    srv_state_dispose(&st2);

    /* a 2 x 2 m emitting panel lights the scene itself; a 1 cm one on a 1 m box does not */
    for (int big = 1; big >= 0; big--) {
        rd_scene s3;
        rd_scene_init(&s3);
        rd_tri_list t = {0};
        uint32_t glow = rd_build_material(&s3, "glow", 0, 0, 0, 2, 2, 2);
        float h = big ? 1.0f : 0.005f;
        const float a[3] = {-h, -h, 1}, b[3] = {h, -h, 1}, c[3] = {h, h, 1}, d[3] = {-h, h, 1};
        rd_tris_quad(&t, a, b, c, d, glow);
        if (!big) {
            const float lo[3] = {-0.5f, -0.5f, 0}, hi[3] = {0.5f, 0.5f, 1};
            rd_tris_box(&t, lo, hi, 0);
        }
        rd_tris_commit(&t, &s3, "panel");
        char err[128];
        CHECK(rd_scene_update(&s3, err, sizeof err));
        srv_state_set_scene(&st, &s3, "test", 2);
        CHECKF(st.default_lighting == !big && st.scene.light_count == (big ? 0u : 1u),
               "%s emitter: default lighting %d", big ? "large" : "small", st.default_lighting);
        CHECK(st.lighting.emitted_w > 0 &&
              (st.lighting.emitted_w >= st.lighting.threshold_w) == big);
    }
    srv_state_dispose(&st);
}

/* POST /v1/views/{id}/pick bodies, and the upload's file name (PUT /v1/scene?name=). */
static void test_pick_and_file_name(void)
{
    srv_api_error e;
    float pt[2] = {-1, -1};
    struct {
        const char *body;
        bool ok;
    } cases[] = {
        {"{\"x\":0.25,\"y\":1}", true},
        {"{\"y\":0,\"x\":0}", true},
        {"{\"x\":0.5}", false},
        {"{\"x\":1.0001,\"y\":0}", false},
        {"{\"x\":0,\"y\":-0.5}", false},
        {"{\"x\":\"0\",\"y\":0}", false},
        {"{\"x\":0,\"y\":0,\"z\":0}", false},
        {"{\"x\":0,\"x\":0,\"y\":0}", false},
        {"{\"x\":null,\"y\":0}", false},
        {"{}", false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        cJSON *j = srv_json_parse_object(cases[i].body, strlen(cases[i].body), &e);
        bool ok = j && srv_json_pick_request(j, pt, &e);
        CHECKF(ok == cases[i].ok, "%s", cases[i].body);
        if (!ok)
            CHECKF(e.status == 400 && e.message[0], "%s: a 400 with a sentence", cases[i].body);
        cJSON_Delete(j);
    }
    const char *body = "{\"x\":0.25,\"y\":1}";
    cJSON *j = srv_json_parse_object(body, strlen(body), &e);
    CHECK(j && srv_json_pick_request(j, pt, &e) && pt[0] == 0.25f && pt[1] == 1.0f);
    cJSON_Delete(j);

    char out[SRV_FILE_NAME_MAX];
    struct {
        const char *raw, *want;
    } names[] = {
        {"model.glb", "model.glb"},
        {"dir/sub\\scene.gltf", "scene.gltf"},
        {"a\x01"
         "b\x7f.glb",
         "a_b_.glb"},
        {"\xc3\xa9t\xc3\xa9.glb", "\xc3\xa9t\xc3\xa9.glb"}, /* UTF-8 kept */
        {"\xff\xc3(\xed\xa0\x80.glb", "__(___.glb"},        /* not UTF-8, a surrogate */
        {"\xe2\x82", "__"},                                 /* cut short */
    };
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        CHECK(srv_state_clean_file_name(names[i].raw, out));
        CHECKF(strcmp(out, names[i].want) == 0, "'%s' -> '%s'", names[i].raw, out);
    }
    CHECK(!srv_state_clean_file_name("dir/", out) && out[0] == 0);
    CHECK(!srv_state_clean_file_name("", out) && !srv_state_clean_file_name(NULL, out));
    /* long names end on a character boundary */
    char lng[400];
    for (int i = 0; i < 199; i++)
        memcpy(lng + 2 * i, "\xc3\xa9", 2);
    lng[398] = 'x';
    lng[399] = 0;
    CHECK(srv_state_clean_file_name(lng, out) && strlen(out) == SRV_FILE_NAME_MAX - 2);
}

int main(void)
{
    test_pick_and_file_name();
    test_default_lighting();
    test_bodies();
    test_patch_shapes();
    test_state();
    return test_finish();
}
