/* test_gltf.c: the glTF loader (renderer/gltf/gltf_loader.h) on files built here in memory:
 * JSON text with base64 data URIs, GLB containers, PNG textures written with libpng, and a
 * battery of broken files that must fail with a clear message, never a crash. */
#include <math.h>
#include <png.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gltf_builder.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/xform.h"
#include "test_util.h"

/* ---- tests ------------------------------------------------------------------------------ */

static void check_world_quad(const rd_scene *s, uint32_t node)
{
    /* quad rotated 90 degrees about Z by node 1 and moved by (10, 0, 0) by its parent */
    float p[3];
    const float *w = s->nodes[node].world;
    rd_mat4_transform_point(w, (float[3]){1, 0, 0}, p);
    CHECK(near3(p, 10, 1, 0));
    rd_mat4_transform_point(w, (float[3]){1, 1, 0}, p);
    CHECK(near3(p, 9, 1, 0));
    CHECK(near3(s->bounds_min, 9, 0, 0) && near3(s->bounds_max, 10, 1, 0));
}

#define HIERARCHY_REST                                                                             \
    "'meshes':[" QUAD_MESH "],"                                                                    \
    "'nodes':[{'name':'parent','translation':[10,0,0],'children':[1]},"                            \
    "{'name':'child','rotation':[0,0,0.70710678,0.70710678],'mesh':0}],"                           \
    "'scenes':[{'nodes':[0]}],'scene':0"

static void test_indexed_hierarchy(void)
{
    bin b;
    std_bin(&b, NULL);
    char *j = gltf_json(&b, 0, NULL, NULL, HIERARCHY_REST);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.mesh_count == 1 && s.meshes[0].tri_count == 2);
    CHECK(s.node_count == 2 && s.instance_count == 1 && s.tri_total == 2);
    CHECK(s.nodes[0].parent == -1 && s.nodes[1].parent == 0 && s.nodes[1].mesh == 0);
    CHECK(s.nodes[0].name && strcmp(s.nodes[0].name, "parent") == 0);
    CHECK(s.instances[0].node == 1 && s.instances[0].mesh == 0);
    const rd_mesh *m = &s.meshes[0];
    /* triangles (0 1 2) and (0 2 3) in object space */
    CHECK(near3(&m->positions[0], 0, 0, 0) && near3(&m->positions[3], 1, 0, 0) &&
          near3(&m->positions[6], 1, 1, 0));
    CHECK(near3(&m->positions[9], 0, 0, 0) && near3(&m->positions[12], 1, 1, 0) &&
          near3(&m->positions[15], 0, 1, 0));
    CHECK(near3(&m->normals[0], 0, 0, 1) && near3(&m->normals[15], 0, 0, 1));
    CHECK(m->uvs[2] == 1.0f && m->uvs[3] == 0.0f && m->uvs[10] == 0.0f && m->uvs[11] == 1.0f);
    CHECK(m->material[0] == 0 && m->material[1] == 0);
    CHECK(s.material_count == 1);
    check_world_quad(&s, 1);
    CHECK(s.warning_count == 0);
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_index_types(void)
{
    bin b;
    std_bin(&b, NULL);
    /* primitives with u8 indices, u32 indices, no indices (TRIANGLES over 3 vertices) */
    const char *rest = "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':4},"
                       "{'attributes':{'POSITION':0},'indices':5},{'attributes':{'POSITION':6}}]}],"
                       "'nodes':[{'mesh':0}]";
    char *j = gltf_json(&b, 0, NULL,
                        STD_ACCESSORS ",{'bufferView':0,'componentType':5126,'count':3,"
                                      "'type':'VEC3'}",
                        rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.mesh_count == 1 && s.meshes[0].tri_count == 5);
    const float *p = s.meshes[0].positions;
    for (int t = 0; t < 4; t += 2) { /* u8 then u32: (0 1 2) (0 2 3) */
        CHECK(near3(&p[t * 9 + 3], 1, 0, 0) && near3(&p[t * 9 + 6], 1, 1, 0));
        CHECK(near3(&p[t * 9 + 9 + 6], 0, 1, 0));
    }
    CHECK(near3(&p[36], 0, 0, 0) && near3(&p[39], 1, 0, 0) && near3(&p[42], 1, 1, 0));
    /* no NORMAL: flat normals, counter-clockwise from +Z */
    CHECK(near3(&s.meshes[0].normals[0], 0, 0, 1) && near3(&s.meshes[0].normals[42], 0, 0, 1));
    /* no nodes' scenes: every root is used */
    CHECK(s.instance_count == 1);
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_flat_normals_and_modes(void)
{
    /* clockwise quad (reversed order) must get -Z flat normals */
    static const float cw[12] = {0, 0, 0, 0, 1, 0, 1, 1, 0, 1, 0, 0};
    bin b;
    std_bin(&b, cw);
    const char *rest =
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':3},"
        "{'attributes':{'POSITION':0},'mode':5},{'attributes':{'POSITION':0},'mode':6},"
        "{'attributes':{'POSITION':0},'mode':0}]}],"
        "'nodes':[{'mesh':0}]";
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.meshes[0].tri_count == 2 + 2 + 2);
    const float *n = s.meshes[0].normals, *p = s.meshes[0].positions;
    CHECK(near3(&n[0], 0, 0, -1) && near3(&n[9], 0, 0, -1));
    /* strip of 4 vertices: (0 1 2) (1 3 2) */
    CHECK(near3(&p[18 + 0], 0, 0, 0) && near3(&p[18 + 3], 0, 1, 0) && near3(&p[18 + 6], 1, 1, 0));
    CHECK(near3(&p[27 + 0], 0, 1, 0) && near3(&p[27 + 3], 1, 0, 0) && near3(&p[27 + 6], 1, 1, 0));
    /* fan: (1 2 0) (2 3 0) */
    CHECK(near3(&p[36 + 0], 0, 1, 0) && near3(&p[36 + 3], 1, 1, 0) && near3(&p[36 + 6], 0, 0, 0));
    CHECK(near3(&p[45 + 0], 1, 1, 0) && near3(&p[45 + 3], 1, 0, 0) && near3(&p[45 + 6], 0, 0, 0));
    CHECK(has_warning(&s, "points or lines"));
    rd_scene_destroy(&s);
    free(j);

    /* a mesh of nothing but points: no mesh, no instance */
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'mode':0}]}],"
                  "'nodes':[{'mesh':0}]");
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.mesh_count == 0 && s.instance_count == 0 && s.node_count == 1);
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_matrix_node_and_sparse(void)
{
    bin b;
    std_bin(&b, NULL);
    /* accessor 6: POSITION with vertex 2 replaced by (5,5,5) through a sparse accessor */
    const char *acc = STD_ACCESSORS
        ",{'bufferView':0,'componentType':5126,'count':4,'type':'VEC3','sparse':{'count':1,"
        "'indices':{'bufferView':6,'componentType':5121},'values':{'bufferView':7}}}"
        ",{'componentType':5126,'count':3,'type':'VEC3','sparse':{'count':1,"
        "'indices':{'bufferView':6,'componentType':5121},'values':{'bufferView':7}}}";
    const char *rest =
        "'meshes':[{'primitives':[{'attributes':{'POSITION':6},'indices':3}]},"
        "{'primitives':[{'attributes':{'POSITION':7}}]}],"
        "'nodes':[{'matrix':[2,0,0,0, 0,2,0,0, 0,0,2,0, 1,2,3,1],'mesh':0},{'mesh':1}]";
    char *j = gltf_json(&b, 0, NULL, acc, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.nodes[0].has_matrix);
    float p[3];
    rd_mat4_transform_point(s.nodes[0].world, (float[3]){1, 1, 0}, p);
    CHECK(near3(p, 3, 4, 3));
    CHECK(near3(&s.meshes[0].positions[6], 5, 5, 5)); /* vertex 2 of triangle (0 1 2) */
    CHECK(near3(&s.meshes[0].positions[3], 1, 0, 0)); /* untouched vertex 1 */
    /* sparse without a buffer view: zeros except vertex 2 */
    CHECK(near3(&s.meshes[1].positions[0], 0, 0, 0) && near3(&s.meshes[1].positions[6], 5, 5, 5));
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_materials(void)
{
    bin b;
    std_bin(&b, NULL);
    const char *rest =
        "'extensionsUsed':['KHR_materials_emissive_strength'],"
        "'materials':[{'name':'glow','pbrMetallicRoughness':{'baseColorFactor':[0.5,0.25,1,0.75]},"
        "'emissiveFactor':[1,0.5,0],'extensions':{'KHR_materials_emissive_strength':"
        "{'emissiveStrength':4}},'doubleSided':true,'alphaMode':'MASK','alphaCutoff':0.3},"
        "{'alphaMode':'BLEND'}],"
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':3,'material':1},"
        "{'attributes':{'POSITION':0},'indices':4,'material':0},"
        "{'attributes':{'POSITION':0},'indices':5}]}],"
        "'nodes':[{'mesh':0}]";
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.material_count == 3);
    const rd_material *g = &s.materials[1];
    CHECK(g->name && strcmp(g->name, "glow") == 0);
    CHECK(g->base_color[0] == 0.5f && g->base_color[1] == 0.25f && g->base_color[2] == 1.0f &&
          g->base_color[3] == 0.75f);
    CHECK(near3(g->emission, 4, 2, 0));
    CHECK(g->double_sided && g->alpha_mode == RD_ALPHA_MASK &&
          fabsf(g->alpha_cutoff - 0.3f) < 1e-6f);
    CHECK(g->base_color_texture == -1 && g->emissive_texture == -1);
    CHECK(s.materials[2].alpha_mode == RD_ALPHA_BLEND && !s.materials[2].double_sided);
    CHECK(s.materials[2].alpha_cutoff == 0.5f && s.materials[2].base_color[0] == 1.0f);
    const uint32_t *mat = s.meshes[0].material;
    CHECK(mat[0] == 2 && mat[1] == 2 && mat[2] == 1 && mat[3] == 1 && mat[4] == 0 && mat[5] == 0);
    CHECK(!has_warning(&s, "emissive_strength"));
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

/* 2x2 RGBA, 2x1 16-bit grey, 1x2 RGB */
static const uint8_t kGrey16[4] = {0xff, 0xff, 0x80, 0x10};
static const uint8_t kRgb[6] = {10, 20, 30, 40, 50, 60};

static void check_textures(const rd_scene *s)
{
    CHECK(s->texture_count == 3);
    if (s->texture_count != 3) return;
    const rd_material *m = &s->materials[1];
    CHECK(m->base_color_texture >= 0 && m->emissive_texture >= 0);
    const rd_texture *t = &s->textures[m->base_color_texture];
    CHECK(t->width == 2 && t->height == 2 && memcmp(t->rgba, kRgba, 16) == 0);
    CHECK(t->wrap_s == RD_WRAP_CLAMP && t->wrap_t == RD_WRAP_MIRROR && t->nearest);
    const rd_texture *e = &s->textures[m->emissive_texture];
    CHECK(e->width == 2 && e->height == 1);
    CHECK(e->rgba[0] == 255 && e->rgba[1] == 255 && e->rgba[2] == 255 && e->rgba[3] == 255);
    CHECK(e->rgba[4] == 128 && e->rgba[5] == 128 && e->rgba[7] == 255);
    CHECK(e->wrap_s == RD_WRAP_REPEAT && e->wrap_t == RD_WRAP_REPEAT && !e->nearest);
    const rd_texture *r = &s->textures[s->materials[2].base_color_texture];
    static const uint8_t want[8] = {10, 20, 30, 255, 40, 50, 60, 255};
    CHECK(r->width == 1 && r->height == 2 && memcmp(r->rgba, want, 8) == 0);
    CHECK(s->materials[2].emissive_texture == -1); /* TEXCOORD_1: ignored with a warning */
    CHECK(has_warning(s, "TEXCOORD_1"));
}

#define TEXTURE_MATERIALS                                                                          \
    "'samplers':[{'magFilter':9728,'wrapS':33071,'wrapT':33648}],"                                 \
    "'textures':[{'source':0,'sampler':0},{'source':1},{'source':2}],"                             \
    "'materials':[{'pbrMetallicRoughness':{'baseColorTexture':{'index':0}},"                       \
    "'emissiveTexture':{'index':1}},{'pbrMetallicRoughness':{'baseColorTexture':{'index':2}},"     \
    "'emissiveTexture':{'index':0,'texCoord':1}}],"                                                \
    "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'material':0}]}],'nodes':[{'mesh':0}]"

static void test_textures(void)
{
    bin png[3];
    make_png(&png[0], 2, 2, PNG_COLOR_TYPE_RGB_ALPHA, 8, kRgba);
    make_png(&png[1], 2, 1, PNG_COLOR_TYPE_GRAY, 16, kGrey16);
    make_png(&png[2], 1, 2, PNG_COLOR_TYPE_RGB, 8, kRgb);
    char *uri[3];
    for (int i = 0; i < 3; i++)
        uri[i] = png_data_uri(&png[i]);
    bin b;
    std_bin(&b, NULL);
    char *rest =
        test_xprintf("'images':[{'uri':'%s'},{'uri':'%s'},{'uri':'%s'}]," TEXTURE_MATERIALS, uri[0],
                     uri[1], uri[2]);
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    check_textures(&s);
    rd_scene_destroy(&s);
    free(j);
    free(rest);

    /* the same images stored in the GLB BIN chunk through buffer views */
    bin g = {0};
    bin_raw(&g, b.p, b.n);
    size_t off[3];
    for (int i = 0; i < 3; i++)
        off[i] = bin_put(&g, png[i].p, png[i].n);
    char *views = test_xprintf(STD_VIEWS ",{'buffer':0,'byteOffset':%zu,'byteLength':%zu},"
                                         "{'buffer':0,'byteOffset':%zu,'byteLength':%zu},"
                                         "{'buffer':0,'byteOffset':%zu,'byteLength':%zu}",
                               off[0], png[0].n, off[1], png[1].n, off[2], png[2].n);
    rest = test_xprintf(
        "'images':[{'bufferView':8,'mimeType':'image/png'},{'bufferView':9,"
        "'mimeType':'image/png'},{'bufferView':10,'mimeType':'image/png'}]," TEXTURE_MATERIALS);
    j = gltf_json(&g, 1, views, NULL, rest);
    size_t size;
    uint8_t *glb = make_glb(j, &g, &size);
    CHECKF(rd_gltf_load_memory(glb, size, NULL, NULL, &s, gltf_err, sizeof gltf_err) == RD_GLTF_OK,
           "%s", gltf_err);
    check_textures(&s);
    rd_scene_destroy(&s);

    /* an image that is not a PNG fails when a material uses it, not before */
    free(rest);
    rest = test_xprintf("'images':[{'uri':'data:image/png;base64,AAAAAAAA'}],"
                        "'textures':[{'source':0}],'materials':[{'emissiveTexture':{'index':0}}]");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, rest);
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "image 0 could not be decoded");
    free(rest);
    rest = test_xprintf(
        "'images':[{'uri':'data:image/png;base64,AAAAAAAA'}],'textures':[{'source':0}]");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, rest);
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.texture_count == 0);
    rd_scene_destroy(&s);

    free(j);
    free(rest);
    free(views);
    free(glb);
    free(g.p);
    free(b.p);
    for (int i = 0; i < 3; i++) {
        free(uri[i]);
        free(png[i].p);
    }
}

static void test_lights(void)
{
    bin b;
    std_bin(&b, NULL);
    const char *rest =
        "'extensionsUsed':['KHR_lights_punctual'],"
        "'extensions':{'KHR_lights_punctual':{'lights':["
        "{'type':'point','color':[1,0.5,0.25],'intensity':20,'range':10,'name':'bulb'},"
        "{'type':'spot','intensity':5,'spot':{'innerConeAngle':0.2,'outerConeAngle':0.6}},"
        "{'type':'directional','intensity':3},{'type':'spot','spot':{}}]}},"
        "'nodes':[{'translation':[0,5,0],'extensions':{'KHR_lights_punctual':{'light':0}}},"
        "{'translation':[1,2,3],'rotation':[-0.70710678,0,0,0.70710678],"
        "'extensions':{'KHR_lights_punctual':{'light':1}}},"
        "{'extensions':{'KHR_lights_punctual':{'light':2}},'children':[3]},"
        "{'translation':[0,0,1],'extensions':{'KHR_lights_punctual':{'light':3}}}],"
        "'scenes':[{'nodes':[0,1,2]}]";
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.light_count == 4 && s.warning_count == 0);
    if (s.light_count == 4) {
        const rd_light *l = s.lights;
        CHECK(l[0].type == RD_LIGHT_POINT && near3(l[0].color, 1, 0.5f, 0.25f));
        CHECK(l[0].intensity == 20.0f && l[0].range == 10.0f && near3(l[0].position, 0, 5, 0));
        CHECK(l[0].name && strcmp(l[0].name, "bulb") == 0);
        CHECK(l[1].type == RD_LIGHT_SPOT && near3(l[1].position, 1, 2, 3));
        CHECK(near3(l[1].direction, 0, -1, 0)); /* -Z turned down by -90 degrees about X */
        CHECK(fabsf(l[1].inner_cone - 0.2f) < 1e-6f && fabsf(l[1].outer_cone - 0.6f) < 1e-6f);
        CHECK(near3(l[1].color, 1, 1, 1) && l[1].intensity == 5.0f);
        CHECK(l[2].type == RD_LIGHT_DIRECTIONAL && near3(l[2].direction, 0, 0, -1));
        CHECK(l[2].intensity == 3.0f && l[2].node >= 0);
        CHECK(l[3].inner_cone == 0.0f && fabsf(l[3].outer_cone - 0.78539816f) < 1e-6f);
        CHECK(l[3].intensity == 1.0f && near3(l[3].position, 0, 0, 1));
    }
    rd_scene_destroy(&s);
    free(j);

    j = gltf_json(&b, 0, NULL, NULL,
                  "'extensions':{'KHR_lights_punctual':{'lights':[{'type':'spot','spot':"
                  "{'innerConeAngle':0.8,'outerConeAngle':0.5}}]}},"
                  "'nodes':[{'extensions':{'KHR_lights_punctual':{'light':0}}}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "spot cone");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'nodes':[{'extensions':{'KHR_lights_punctual':{'light':3}}}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "light");
    free(j);
    free(b.p);
}

static void test_cameras(void)
{
    bin b;
    std_bin(&b, NULL);
    const char *rest =
        "'cameras':[{'type':'perspective','name':'main','perspective':{'yfov':0.8,"
        "'aspectRatio':1.5,'znear':0.1}},{'type':'orthographic','orthographic':{'xmag':1,"
        "'ymag':1,'zfar':10,'znear':0.1}},{'type':'perspective','perspective':{'yfov':0.5,"
        "'znear':0.01}}],"
        "'nodes':[{'translation':[0,0,5],'camera':0},{'camera':1},"
        "{'rotation':[0,0.70710678,0,0.70710678],'camera':2}]";
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.camera_count == 2);
    if (s.camera_count == 2) {
        const rd_camera *c = s.cameras;
        CHECK(c[0].name && strcmp(c[0].name, "main") == 0);
        CHECK(fabsf(c[0].yfov - 0.8f) < 1e-6f && c[0].aspect == 1.5f &&
              fabsf(c[0].znear - 0.1f) < 1e-6f);
        CHECK(near3(c[0].position, 0, 0, 5) && near3(c[0].forward, 0, 0, -1) &&
              near3(c[0].up, 0, 1, 0));
        CHECK(c[1].aspect == 0.0f && near3(c[1].forward, -1, 0, 0)); /* yawed 90 degrees left */
    }
    CHECK(has_warning(&s, "orthographic"));
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_glb_and_files(void)
{
    bin b;
    std_bin(&b, NULL);
    char *j = gltf_json(&b, 1, NULL, NULL, HIERARCHY_REST);
    size_t size;
    uint8_t *glb = make_glb(j, &b, &size);
    rd_scene s;
    CHECKF(rd_gltf_load_memory(glb, size, NULL, NULL, &s, gltf_err, sizeof gltf_err) == RD_GLTF_OK,
           "%s", gltf_err);
    CHECK(s.mesh_count == 1 && s.meshes[0].tri_count == 2 && s.instance_count == 1);
    check_world_quad(&s, 1);
    rd_scene_destroy(&s);

    /* the same file from disk */
    const char *path = test_tmp_path("quad.glb");
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(glb, 1, size, f) == size);
    if (f) fclose(f);
    CHECKF(rd_gltf_load_file(path, NULL, &s, gltf_err, sizeof gltf_err) == RD_GLTF_OK, "%s",
           gltf_err);
    check_world_quad(&s, 1);
    rd_scene_destroy(&s);
    CHECK(rd_gltf_load_file(test_tmp_path("missing.glb"), NULL, &s, gltf_err, sizeof gltf_err) ==
          RD_GLTF_ERR_IO);
    CHECK(scene_is_empty(&s));

    /* every truncation of the GLB fails cleanly */
    int all_failed = 1, all_empty = 1;
    for (size_t n = 0; n < size; n++) {
        uint8_t *cut = malloc(n ? n : 1); /* exact-size copy: ASan sees any over-read */
        memcpy(cut, glb, n);
        rd_gltf_result r = rd_gltf_load_memory(cut, n, NULL, NULL, &s, gltf_err, sizeof gltf_err);
        all_failed &= r != RD_GLTF_OK;
        all_empty &= scene_is_empty(&s);
        if (r == RD_GLTF_OK) fprintf(stderr, "truncated to %zu bytes: loaded\n", n);
        rd_scene_destroy(&s);
        free(cut);
    }
    CHECK(all_failed && all_empty);
    CHECK(rd_gltf_load_memory(glb, 30, NULL, NULL, &s, gltf_err, sizeof gltf_err) ==
          RD_GLTF_ERR_PARSE);
    CHECKF(strstr(gltf_err, "truncated") != NULL, "%s", gltf_err);
    free(glb);
    free(j);

    /* external .bin and .png next to a .gltf */
    const char *bin_path = test_tmp_path("quad.bin");
    f = fopen(bin_path, "wb");
    CHECK(f && fwrite(b.p, 1, b.n, f) == b.n);
    if (f) fclose(f);
    bin png;
    make_png(&png, 2, 2, PNG_COLOR_TYPE_RGB_ALPHA, 8, kRgba);
    f = fopen(test_tmp_path("quad.png"), "wb");
    CHECK(f && fwrite(png.p, 1, png.n, f) == png.n);
    if (f) fclose(f);
    char *tmpl =
        test_xprintf("{'asset':{'version':'2.0'},'buffers':[{'byteLength':%zu,'uri':'%%s'}],"
                     "'bufferViews':[" STD_VIEWS "],'accessors':[" STD_ACCESSORS "],"
                     "'images':[{'uri':'%%s'}],'textures':[{'source':0}],"
                     "'materials':[{'pbrMetallicRoughness':{'baseColorTexture':{'index':0}}}],"
                     "'meshes':[" QUAD_MESH "],'nodes':[{'mesh':0}]}",
                     b.n);
    char *tq = test_jq(tmpl);
    struct {
        const char *buffer, *image;
        rd_gltf_result want;
        const char *needle;
    } cases[] = {
        {"quad.bin", "quad.png", RD_GLTF_OK, ""},
        {"qu%61d.bin", "./quad.png", RD_GLTF_OK, ""},
        {"nope.bin", "quad.png", RD_GLTF_ERR_IO, "buffer 0 'nope.bin' could not be loaded"},
        {"../quad.bin", "quad.png", RD_GLTF_ERR_IO, "'..'"},
        {"%2e%2e/test-output/quad.bin", "quad.png", RD_GLTF_ERR_IO, "'..'"},
        {"/etc/hostname", "quad.png", RD_GLTF_ERR_IO, "absolute"},
        {"quad.bin", "../quad.png", RD_GLTF_ERR_IO, "image 0 '../quad.png' could not be loaded"},
        {"quad.bin", "nope.png", RD_GLTF_ERR_IO, "image 0 'nope.png' could not be loaded"},
        {"quad.bin", "quad.bin", RD_GLTF_ERR_INVALID, "could not be decoded"},
        {"quad.png", "quad.png", RD_GLTF_ERR_INVALID, "byteLength"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char *text = test_xprintf(tq, cases[i].buffer, cases[i].image);
        const char *gpath = test_tmp_path("quad.gltf");
        f = fopen(gpath, "wb");
        CHECK(f && fwrite(text, 1, strlen(text), f) == strlen(text));
        if (f) fclose(f);
        gltf_err[0] = '\0';
        rd_gltf_result r = rd_gltf_load_file(gpath, NULL, &s, gltf_err, sizeof gltf_err);
        CHECKF(r == cases[i].want, "case %zu: %s: %s", i, rd_gltf_strerror(r), gltf_err);
        CHECKF(strstr(gltf_err, cases[i].needle) != NULL, "case %zu: '%s' lacks '%s'", i, gltf_err,
               cases[i].needle);
        if (r == RD_GLTF_OK) {
            CHECK(s.texture_count == 1 && s.textures[0].width == 2 &&
                  memcmp(s.textures[0].rgba, kRgba, 16) == 0);
            CHECK(s.meshes[0].tri_count == 2);
        }
        rd_scene_destroy(&s);
        /* from memory: with the folder as base it works the same; without, no file is read */
        r = rd_gltf_load_memory(text, strlen(text), "test-output", NULL, &s, gltf_err,
                                sizeof gltf_err);
        CHECKF(r == cases[i].want, "case %zu (memory): %s: %s", i, rd_gltf_strerror(r), gltf_err);
        rd_scene_destroy(&s);
        if (i == 0) {
            r = rd_gltf_load_memory(text, strlen(text), NULL, NULL, &s, gltf_err, sizeof gltf_err);
            /* the message tells an uploader what to do instead */
            CHECKF(r == RD_GLTF_ERR_IO && strstr(gltf_err, "upload a .glb"), "%s", gltf_err);
        }
        free(text);
    }
    free(tq);
    free(tmpl);
    free(png.p);
    free(b.p);
}

static void test_warnings(void)
{
    bin b;
    std_bin(&b, NULL);
    const char *rest = "'extensionsUsed':['EXT_fancy_thing','KHR_lights_punctual'],"
                       "'skins':[{'joints':[1]}],"
                       "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':3,"
                       "'targets':[{'POSITION':0}]}]}],"
                       "'materials':[{'alphaMode':'SHINY'}],"
                       "'nodes':[{'mesh':0,'skin':0,'children':[1]},{}],"
                       "'scenes':[{'nodes':[0]}]";
    char *j = gltf_json(&b, 0, NULL, NULL, rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(has_warning(&s, "EXT_fancy_thing"));
    CHECK(!has_warning(&s, "KHR_lights_punctual"));
    /* skins and morph targets load (test_skin.c); a mesh without JOINTS_0 is not skinned */
    CHECK(!has_warning(&s, "skin"));
    CHECK(!has_warning(&s, "morph"));
    CHECK(has_warning(&s, "SHINY"));
    CHECK(s.warning_count == 2);
    CHECK(s.skin_count == 1 && s.mesh_count == 1 && s.meshes[0].deform &&
          s.meshes[0].deform->target_count == 1 && s.meshes[0].deform->influences == 0);
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

/* glTF 2.0 metallic-roughness: factors, the three data textures with scale and strength,
 * TANGENT, the specification's defaults, and warnings for BLEND, TEXCOORD_1 and unsupported
 * material extensions (one per extension, not one more for extensionsUsed). */
static void test_pbr_materials(void)
{
    bin png;
    make_png(&png, 2, 2, PNG_COLOR_TYPE_RGB_ALPHA, 8, kRgba);
    char *uri = png_data_uri(&png);
    bin b;
    std_bin(&b, NULL);
    const float tangents[16] = {1, 0, 0, 1, 1, 0, 0, -1, 0, 1, 0, 1, 0, 0, 1, -1};
    size_t off = bin_put(&b, tangents, sizeof tangents);
    char *views = test_xprintf(STD_VIEWS ",{'buffer':0,'byteOffset':%zu,'byteLength':64}", off);
    char *rest = test_xprintf(
        "'extensionsUsed':['KHR_materials_clearcoat','KHR_materials_transmission'],"
        "'images':[{'uri':'%s'}],'textures':[{'source':0},{'source':0},{'source':0}],"
        "'materials':[{'pbrMetallicRoughness':{'metallicFactor':0.25,'roughnessFactor':0.75,"
        "'metallicRoughnessTexture':{'index':1}},'normalTexture':{'index':2,'scale':0.5},"
        "'occlusionTexture':{'index':0,'strength':0.3},'alphaMode':'BLEND',"
        "'extensions':{'KHR_materials_clearcoat':{},'KHR_materials_transmission':{}}},"
        "{'extensions':{'KHR_materials_clearcoat':{'clearcoatFactor':1}},"
        "'normalTexture':{'index':0,'texCoord':1}}],"
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2,"
        "'TANGENT':6},'indices':3,'material':0},{'attributes':{'POSITION':0},'indices':3,"
        "'material':1}]}],'nodes':[{'mesh':0}]",
        uri);
    char *j = gltf_json(
        &b, 0, views,
        STD_ACCESSORS ",{'bufferView':8,'componentType':5126,'count':4,'type':'VEC4'}", rest);
    rd_scene s;
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
    CHECK(s.material_count == 3 && s.texture_count == 3); /* one per glTF texture used */
    if (s.material_count == 3) {
        const rd_material *m = &s.materials[1], *d = &s.materials[2];
        CHECK(m->metallic == 0.25f && m->roughness == 0.75f && m->specular == 1.0f);
        CHECK(m->normal_scale == 0.5f && fabsf(m->occlusion_strength - 0.3f) < 1e-6f);
        /* rd textures in order of first use: glTF textures 1, 2, 0 */
        CHECK(m->metallic_roughness_texture == 0 && m->normal_texture == 1 &&
              m->occlusion_texture == 2 && m->base_color_texture == -1);
        CHECK(m->alpha_mode == RD_ALPHA_BLEND);
        /* the specification's defaults: metallic 1, roughness 1, scale 1, strength 1 */
        CHECK(d->metallic == 1.0f && d->roughness == 1.0f && d->specular == 1.0f);
        CHECK(d->normal_scale == 1.0f && d->occlusion_strength == 1.0f);
        CHECK(d->metallic_roughness_texture == -1 && d->normal_texture == -1 &&
              d->occlusion_texture == -1);
        /* the default material stays a white Lambertian */
        CHECK(s.materials[0].metallic == 0.0f && s.materials[0].specular == 0.0f);
    }
    const rd_mesh *mesh = &s.meshes[0];
    CHECK(mesh->tri_count == 4 && mesh->tangents != NULL);
    if (mesh->tangents) {
        /* triangle 0 = vertices 0 1 2, triangle 1 = 0 2 3; the second primitive has none */
        CHECK(memcmp(&mesh->tangents[0], &tangents[0], 12 * sizeof(float)) == 0);
        CHECK(memcmp(&mesh->tangents[20], &tangents[12], 4 * sizeof(float)) == 0);
        for (int k = 24; k < 48; k++)
            CHECK(mesh->tangents[k] == 0.0f);
    }
    CHECK(has_warning(&s, "BLEND"));
    CHECK(has_warning(&s, "KHR_materials_clearcoat (on 2 material(s))"));
    CHECK(has_warning(&s, "KHR_materials_transmission (on 1 material(s))"));
    CHECK(has_warning(&s, "normal texture with TEXCOORD_1"));
    CHECK(s.warning_count == 4);
    rd_scene_destroy(&s);
    free(j);
    free(rest);
    free(views);
    free(uri);
    free(png.p);
    free(b.p);
}

int main(void)
{
    test_indexed_hierarchy();
    test_index_types();
    test_flat_normals_and_modes();
    test_matrix_node_and_sparse();
    test_materials();
    test_pbr_materials();
    test_textures();
    test_lights();
    test_cameras();
    test_glb_and_files();
    test_warnings();
    return test_finish();
}
