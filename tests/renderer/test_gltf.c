/* test_gltf.c: the glTF loader (renderer/gltf_loader.cpp) on files built here in memory:
 * JSON text with base64 data URIs, GLB containers, PNG textures written with libpng, and a
 * battery of broken files that must fail with a clear message, never a crash. */
#include <math.h>
#include <png.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/gltf_loader.h"
#include "renderer/xform.h"
#include "test_util.h"

/* ---- byte and string builders ---------------------------------------------------------- */

typedef struct bin {
    uint8_t *p;
    size_t n, cap;
} bin;

static void bin_raw(bin *b, const void *data, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = realloc(b->p, b->cap);
    }
    if (n) memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void bin_align(bin *b, uint8_t fill)
{
    while (b->n % 4)
        bin_raw(b, &fill, 1);
}

/* Appends at a 4-byte aligned offset and returns it. */
static size_t bin_put(bin *b, const void *data, size_t n)
{
    bin_align(b, 0);
    size_t at = b->n;
    bin_raw(b, data, n);
    return at;
}

/* ---- the standard buffer ----------------------------------------------------------------
 * A unit quad in the XY plane: 4 positions (0) 4 normals (48) 4 uvs (96), indices 0 1 2 0 2 3
 * as u16 (128) u8 (140) u32 (148), then a sparse index (172) and a sparse value (176). */
static const float kQuad[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

static void std_bin(bin *b, const float *positions)
{
    static const float normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const float uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const uint16_t i16[6] = {0, 1, 2, 0, 2, 3};
    static const uint8_t i8[6] = {0, 1, 2, 0, 2, 3};
    static const uint32_t i32[6] = {0, 1, 2, 0, 2, 3};
    static const uint8_t sparse_index[1] = {2};
    static const float sparse_value[3] = {5, 5, 5};
    memset(b, 0, sizeof *b);
    bin_put(b, positions ? positions : kQuad, 48);
    bin_put(b, normals, 48);
    bin_put(b, uvs, 32);
    bin_put(b, i16, 12);
    bin_put(b, i8, 6);
    bin_put(b, i32, 24);
    bin_put(b, sparse_index, 1);
    bin_put(b, sparse_value, 12);
    CHECK(b->n == 188);
}

#define STD_VIEWS                                                                                  \
    "{'buffer':0,'byteOffset':0,'byteLength':48},{'buffer':0,'byteOffset':48,'byteLength':48},"    \
    "{'buffer':0,'byteOffset':96,'byteLength':32},{'buffer':0,'byteOffset':128,'byteLength':12},"  \
    "{'buffer':0,'byteOffset':140,'byteLength':6},{'buffer':0,'byteOffset':148,'byteLength':24},"  \
    "{'buffer':0,'byteOffset':172,'byteLength':1},{'buffer':0,'byteOffset':176,'byteLength':12}"
#define STD_ACCESSORS                                                                              \
    "{'bufferView':0,'componentType':5126,'count':4,'type':'VEC3'},"                               \
    "{'bufferView':1,'componentType':5126,'count':4,'type':'VEC3'},"                               \
    "{'bufferView':2,'componentType':5126,'count':4,'type':'VEC2'},"                               \
    "{'bufferView':3,'componentType':5123,'count':6,'type':'SCALAR'},"                             \
    "{'bufferView':4,'componentType':5121,'count':6,'type':'SCALAR'},"                             \
    "{'bufferView':5,'componentType':5125,'count':6,'type':'SCALAR'}"
/* one quad mesh: POSITION 0, NORMAL 1, TEXCOORD_0 2, u16 indices 3 */
#define QUAD_MESH                                                                                  \
    "{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2},'indices':3}]}"

/* A complete glTF JSON text (double quotes). b: buffer 0; glb: no URI (GLB BIN chunk);
 * views/accessors: array items or NULL for the standard ones; rest: more top-level members. */
static char *gltf_json(const bin *b, int glb, const char *views, const char *accessors,
                       const char *rest)
{
    char *uri = NULL;
    if (!glb) {
        char *b64 = test_base64(b->p, b->n);
        uri = test_xprintf(",'uri':'data:application/octet-stream;base64,%s'", b64);
        free(b64);
    }
    char *s = test_xprintf("{'asset':{'version':'2.0'},'buffers':[{'byteLength':%zu%s}],"
                           "'bufferViews':[%s],'accessors':[%s]%s%s}",
                           b->n, uri ? uri : "", views ? views : STD_VIEWS,
                           accessors ? accessors : STD_ACCESSORS, rest && *rest ? "," : "",
                           rest ? rest : "");
    char *j = test_jq(s);
    free(s);
    free(uri);
    return j;
}

/* GLB container: header, JSON chunk padded with spaces, BIN chunk padded with zeros. */
static uint8_t *make_glb(const char *json, const bin *b, size_t *size)
{
    size_t jn = strlen(json), jpad = (jn + 3) & ~(size_t)3;
    size_t bpad = b ? (b->n + 3) & ~(size_t)3 : 0;
    size_t total = 12 + 8 + jpad + (b ? 8 + bpad : 0);
    uint8_t *g = calloc(1, total);
    uint32_t hdr[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)jpad, 0x4E4F534Au};
    memcpy(g, hdr, sizeof hdr);
    memset(g + 20, ' ', jpad);
    memcpy(g + 20, json, jn);
    if (b) {
        uint32_t ch[2] = {(uint32_t)bpad, 0x004E4942u};
        memcpy(g + 20 + jpad, ch, 8);
        memcpy(g + 28 + jpad, b->p, b->n);
    }
    *size = total;
    return g;
}

/* ---- PNG ------------------------------------------------------------------------------- */

static void png_write_cb(png_structp png, png_bytep data, size_t n)
{
    bin_raw((bin *)png_get_io_ptr(png), data, n);
}

/* color_type: PNG_COLOR_TYPE_*; rows packed, 16-bit samples big-endian. */
static void make_png(bin *out, int w, int h, int color_type, int depth, const uint8_t *px)
{
    memset(out, 0, sizeof *out);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        CHECK(!"libpng failed");
        png_destroy_write_struct(&png, &info);
        return;
    }
    png_set_write_fn(png, out, png_write_cb, NULL);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, depth, color_type, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    int channels = color_type == PNG_COLOR_TYPE_GRAY         ? 1
                   : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                   : color_type == PNG_COLOR_TYPE_RGB        ? 3
                                                             : 4;
    size_t row = (size_t)w * (size_t)channels * (size_t)depth / 8;
    for (int y = 0; y < h; y++)
        png_write_row(png, (png_const_bytep)(px + (size_t)y * row));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
}

static char *png_data_uri(const bin *png)
{
    char *b64 = test_base64(png->p, png->n);
    char *uri = test_xprintf("data:image/png;base64,%s", b64);
    free(b64);
    return uri;
}

/* ---- loading helpers -------------------------------------------------------------------- */

static char err[512];

static rd_gltf_result load_text(const char *json, rd_scene *s)
{
    err[0] = '\0';
    return rd_gltf_load_memory(json, strlen(json), NULL, NULL, s, err, sizeof err);
}

static int near3(const float *a, float x, float y, float z)
{
    return fabsf(a[0] - x) < 1e-5f && fabsf(a[1] - y) < 1e-5f && fabsf(a[2] - z) < 1e-5f;
}

static int scene_is_empty(const rd_scene *s)
{
    return s->meshes == NULL && s->mesh_count == 0 && s->materials == NULL &&
           s->material_count == 0 && s->nodes == NULL && s->warnings == NULL &&
           s->warning_count == 0 && s->textures == NULL;
}

static int has_warning(const rd_scene *s, const char *needle)
{
    for (uint32_t i = 0; i < s->warning_count; i++)
        if (strstr(s->warnings[i], needle)) return 1;
    return 0;
}

/* Expects failure with `code` and a message containing `needle`; the scene must be empty. */
static void expect_error(const char *json, rd_gltf_result code, const char *needle, int line)
{
    rd_scene s;
    rd_gltf_result r = load_text(json, &s);
    CHECKF(r == code, "line %d: got %s (%s), wanted %s", line, rd_gltf_strerror(r), err,
           rd_gltf_strerror(code));
    CHECKF(strstr(err, needle) != NULL, "line %d: message '%s' lacks '%s'", line, err, needle);
    CHECKF(scene_is_empty(&s), "line %d: scene not empty after an error", line);
    rd_scene_destroy(&s);
}
#define EXPECT_ERROR(json, code, needle) expect_error(json, code, needle, __LINE__)

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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
static const uint8_t kRgba[16] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 255, 255, 255, 0};
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(rd_gltf_load_memory(glb, size, NULL, NULL, &s, err, sizeof err) == RD_GLTF_OK, "%s",
           err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
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
    CHECKF(rd_gltf_load_memory(glb, size, NULL, NULL, &s, err, sizeof err) == RD_GLTF_OK, "%s",
           err);
    CHECK(s.mesh_count == 1 && s.meshes[0].tri_count == 2 && s.instance_count == 1);
    check_world_quad(&s, 1);
    rd_scene_destroy(&s);

    /* the same file from disk */
    const char *path = test_tmp_path("quad.glb");
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(glb, 1, size, f) == size);
    if (f) fclose(f);
    CHECKF(rd_gltf_load_file(path, NULL, &s, err, sizeof err) == RD_GLTF_OK, "%s", err);
    check_world_quad(&s, 1);
    rd_scene_destroy(&s);
    CHECK(rd_gltf_load_file(test_tmp_path("missing.glb"), NULL, &s, err, sizeof err) ==
          RD_GLTF_ERR_IO);
    CHECK(scene_is_empty(&s));

    /* every truncation of the GLB fails cleanly */
    int all_failed = 1, all_empty = 1;
    for (size_t n = 0; n < size; n++) {
        uint8_t *cut = malloc(n ? n : 1); /* exact-size copy: ASan sees any over-read */
        memcpy(cut, glb, n);
        rd_gltf_result r = rd_gltf_load_memory(cut, n, NULL, NULL, &s, err, sizeof err);
        all_failed &= r != RD_GLTF_OK;
        all_empty &= scene_is_empty(&s);
        if (r == RD_GLTF_OK) fprintf(stderr, "truncated to %zu bytes: loaded\n", n);
        rd_scene_destroy(&s);
        free(cut);
    }
    CHECK(all_failed && all_empty);
    CHECK(rd_gltf_load_memory(glb, 30, NULL, NULL, &s, err, sizeof err) == RD_GLTF_ERR_PARSE);
    CHECKF(strstr(err, "truncated") != NULL, "%s", err);
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
        err[0] = '\0';
        rd_gltf_result r = rd_gltf_load_file(gpath, NULL, &s, err, sizeof err);
        CHECKF(r == cases[i].want, "case %zu: %s: %s", i, rd_gltf_strerror(r), err);
        CHECKF(strstr(err, cases[i].needle) != NULL, "case %zu: '%s' lacks '%s'", i, err,
               cases[i].needle);
        if (r == RD_GLTF_OK) {
            CHECK(s.texture_count == 1 && s.textures[0].width == 2 &&
                  memcmp(s.textures[0].rgba, kRgba, 16) == 0);
            CHECK(s.meshes[0].tri_count == 2);
        }
        rd_scene_destroy(&s);
        /* from memory: with the folder as base it works the same; without, no file is read */
        r = rd_gltf_load_memory(text, strlen(text), "test-output", NULL, &s, err, sizeof err);
        CHECKF(r == cases[i].want, "case %zu (memory): %s: %s", i, rd_gltf_strerror(r), err);
        rd_scene_destroy(&s);
        if (i == 0) {
            r = rd_gltf_load_memory(text, strlen(text), NULL, NULL, &s, err, sizeof err);
            /* the message tells an uploader what to do instead */
            CHECKF(r == RD_GLTF_ERR_IO && strstr(err, "upload a .glb"), "%s", err);
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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
    CHECK(has_warning(&s, "EXT_fancy_thing"));
    CHECK(!has_warning(&s, "KHR_lights_punctual"));
    CHECK(has_warning(&s, "skin"));
    CHECK(has_warning(&s, "morph"));
    CHECK(has_warning(&s, "SHINY"));
    CHECK(s.warning_count == 4);
    rd_scene_destroy(&s);
    free(j);
    free(b.p);
}

static void test_errors(void)
{
    bin b;
    std_bin(&b, NULL);
    char *j;
    rd_scene s;

    EXPECT_ERROR("", RD_GLTF_ERR_PARSE, "empty");
    j = test_jq("{'asset':{'version':'2.0'},'nodes':[{'name':'x'}");
    EXPECT_ERROR(j, RD_GLTF_ERR_PARSE, "JSON");
    free(j);
    EXPECT_ERROR("\x89PNG garbage", RD_GLTF_ERR_PARSE, "JSON");
    EXPECT_ERROR("{\"nodes\":[]}", RD_GLTF_ERR_INVALID, "asset");
    j = test_jq("{'asset':{'version':'1.0'}}");
    EXPECT_ERROR(j, RD_GLTF_ERR_UNSUPPORTED, "version");
    free(j);
    char deep[512];
    memset(deep, '[', 300);
    memset(deep + 300, ']', 200); /* unbalanced too, but depth is checked first */
    deep[500] = '\0';
    EXPECT_ERROR(deep, RD_GLTF_ERR_PARSE, "nests");

    j = gltf_json(&b, 0, NULL, NULL,
                  "'extensionsUsed':['KHR_draco_mesh_compression'],"
                  "'extensionsRequired':['KHR_draco_mesh_compression']");
    EXPECT_ERROR(j, RD_GLTF_ERR_UNSUPPORTED, "KHR_draco_mesh_compression");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'extensionsRequired':['KHR_lights_punctual']");
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", err);
    rd_scene_destroy(&s);
    free(j);

    /* accessor 0 claims 5 vertices in a 4-vertex view */
    j = gltf_json(&b, 0, NULL, "{'bufferView':0,'componentType':5126,'count':5,'type':'VEC3'}",
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0}}]}],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID,
                 "accessor 0 (POSITION of mesh 0 primitive 0) reads past "
                 "the end of buffer view 0");
    free(j);
    /* byteOffset pushes it out too */
    j = gltf_json(&b, 0, NULL,
                  "{'bufferView':0,'byteOffset':4,'componentType':5126,'count':4,'type':'VEC3'}",
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0}}]}],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "reads past");
    free(j);
    /* buffer view larger than its buffer */
    j = gltf_json(&b, 0, "{'buffer':0,'byteOffset':100,'byteLength':100}", "", "");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "buffer view 0 (offset 100, length 100) does not fit");
    free(j);
    j = gltf_json(&b, 0, "{'buffer':3,'byteLength':4}", "", "");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "buffer view 0");
    free(j);
    /* an image buffer view out of range is caught before tinygltf touches it */
    j = gltf_json(&b, 0, NULL, NULL, "'images':[{'bufferView':99,'mimeType':'image/png'}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "image 0");
    free(j);
    /* u8 indices read from the float bytes of vertex 1: 0 0 128 -> out of range */
    j = gltf_json(&b, 0, NULL,
                  STD_ACCESSORS ",{'bufferView':0,'byteOffset':12,'componentType':5121,"
                                "'count':3,'type':'SCALAR'}",
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':6}]}],"
                  "'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "out of range");
    free(j);
    /* wrong accessor types */
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':2}}]}],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "has type VEC2, expected VEC3");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'indices':0}]}],"
                  "'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "indices of mesh 0 primitive 0");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'NORMAL':1}}]}],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "no POSITION");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':9}}]}],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "accessor 9");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'meshes':[{'primitives':[{'attributes':{'POSITION':0},'material':4}]}],"
                  "'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "material 4");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'mesh':2}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "mesh 2");
    free(j);

    /* NaN position */
    float bad[12];
    memcpy(bad, kQuad, sizeof bad);
    bad[7] = NAN;
    bin nb;
    std_bin(&nb, bad);
    j = gltf_json(&nb, 0, NULL, NULL, "'meshes':[" QUAD_MESH "],'nodes':[{'mesh':0}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "POSITION of mesh 0 primitive 0 contains NaN");
    free(j);
    free(nb.p);

    /* hierarchy */
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'children':[1]},{'children':[0]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "cycle");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'children':[0]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "cycle");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'children':[2]},{'children':[2]},{}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "two parents");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'children':[5]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "child 5");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'children':[1]},{}],'scenes':[{'nodes':[1]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "root");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{}],'scenes':[{'nodes':[0]}],'scene':2");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "scene 2");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'rotation':[0,0,1]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "rotation");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL, "'nodes':[{'translation':[1e300,0,0]}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "not finite");
    free(j);

    /* buffers */
    j = test_jq("{'asset':{'version':'2.0'},'buffers':[{'byteLength':8,'uri':'x.bin'}]}");
    EXPECT_ERROR(j, RD_GLTF_ERR_IO,
                 "buffer 0 'x.bin' could not be loaded: a file uploaded alone cannot refer to "
                 "other files: upload a .glb");
    free(j);
    j = test_jq("{'asset':{'version':'2.0'},'buffers':[{'byteLength':8,"
                "'uri':'data:application/octet-stream;base64,AAAA'}]}");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "byteLength");
    free(j);
    j = test_jq("{'asset':{'version':'2.0'},'buffers':[{'byteLength':8,'uri':'data:text/x,abc'}]}");
    EXPECT_ERROR(j, RD_GLTF_ERR_UNSUPPORTED, "data URI");
    free(j);
    j = gltf_json(&b, 0, NULL, NULL,
                  "'images':[{'uri':'data:image/webp;base64,AAAA'}],'textures':[{'source':0}],"
                  "'materials':[{'emissiveTexture':{'index':0}}]");
    EXPECT_ERROR(j, RD_GLTF_ERR_UNSUPPORTED, "image 0 has a data URI");
    free(j);
    j = test_jq("{'asset':{'version':'2.0'},'buffers':[{'byteLength':8}]}");
    EXPECT_ERROR(j, RD_GLTF_ERR_INVALID, "uri");
    free(j);

    /* size limit */
    j = gltf_json(&b, 0, NULL, NULL, "'meshes':[" QUAD_MESH "],'nodes':[{'mesh':0}]");
    rd_gltf_options opt = {.max_triangles = 1};
    CHECK(rd_gltf_load_memory(j, strlen(j), NULL, &opt, &s, err, sizeof err) ==
          RD_GLTF_ERR_TOO_LARGE);
    CHECKF(strstr(err, "triangles") != NULL, "%s", err);
    CHECK(scene_is_empty(&s));
    opt.max_triangles = 2;
    CHECK(rd_gltf_load_memory(j, strlen(j), NULL, &opt, &s, err, sizeof err) == RD_GLTF_OK);
    rd_scene_destroy(&s);
    /* a tiny error buffer is still terminated */
    char small[8];
    CHECK(rd_gltf_load_memory("{", 1, NULL, NULL, &s, small, sizeof small) == RD_GLTF_ERR_PARSE);
    CHECK(strlen(small) == 7);
    free(j);

    CHECK(strcmp(rd_gltf_strerror(RD_GLTF_OK), "ok") == 0);
    CHECK(strcmp(rd_gltf_strerror(RD_GLTF_ERR_TOO_LARGE), "too large") == 0);
    free(b.p);
}

/* Random byte mutations of a valid GLB and glTF text: any result is fine except a crash,
 * a sanitizer report or a non-empty scene after an error. */
static void test_mutations(void)
{
    bin png;
    make_png(&png, 2, 2, PNG_COLOR_TYPE_RGB_ALPHA, 8, kRgba);
    bin b;
    std_bin(&b, NULL);
    size_t off = bin_put(&b, png.p, png.n);
    char *views =
        test_xprintf(STD_VIEWS ",{'buffer':0,'byteOffset':%zu,'byteLength':%zu}", off, png.n);
    const char *rest =
        "'images':[{'bufferView':8,'mimeType':'image/png'}],'textures':[{'source':0}],"
        "'materials':[{'pbrMetallicRoughness':{'baseColorTexture':{'index':0}}}],"
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2},"
        "'indices':3,'material':0}]}],'nodes':[{'mesh':0,'children':[1]},{'mesh':0}],"
        "'scenes':[{'nodes':[0]}]";
    char *j = gltf_json(&b, 1, views, NULL, rest);
    size_t size;
    uint8_t *glb = make_glb(j, &b, &size);
    char *text = gltf_json(&b, 0, views, NULL, rest);
    rd_gltf_options opt = {.max_triangles = 1000};
    rd_scene s;
    CHECKF(rd_gltf_load_memory(glb, size, NULL, &opt, &s, err, sizeof err) == RD_GLTF_OK, "%s",
           err);
    rd_scene_destroy(&s);
    CHECKF(rd_gltf_load_memory(text, strlen(text), NULL, &opt, &s, err, sizeof err) == RD_GLTF_OK,
           "%s", err);
    rd_scene_destroy(&s);

    uint32_t rng = 12345;
    int ok_count = 0, clean = 1;
    for (int iter = 0; iter < 3000; iter++) {
        int use_glb = iter % 2;
        size_t n = use_glb ? size : strlen(text);
        uint8_t *m = malloc(n);
        memcpy(m, use_glb ? glb : (uint8_t *)text, n);
        int edits = 1 + (int)((rng >> 8) % 4);
        for (int e = 0; e < edits; e++) {
            rng = rng * 1664525u + 1013904223u;
            size_t at = (rng >> 4) % n;
            rng = rng * 1664525u + 1013904223u;
            /* text: mostly digits and JSON punctuation, so that structure survives */
            static const char alphabet[] = "0123456789-.e[]{},:\"9";
            m[at] = use_glb && (rng & 1) ? (uint8_t)(rng >> 16)
                                         : (uint8_t)alphabet[(rng >> 16) % (sizeof alphabet - 1)];
        }
        rd_gltf_result r = rd_gltf_load_memory(m, n, NULL, &opt, &s, err, sizeof err);
        if (r == RD_GLTF_OK)
            ok_count++;
        else
            clean &= scene_is_empty(&s);
        rd_scene_destroy(&s);
        free(m);
    }
    CHECK(clean);
    fprintf(stderr, "mutations: %d of 3000 still loaded\n", ok_count);
    free(text);
    free(glb);
    free(j);
    free(views);
    free(b.p);
    free(png.p);
}

int main(void)
{
    test_indexed_hierarchy();
    test_index_types();
    test_flat_normals_and_modes();
    test_matrix_node_and_sparse();
    test_materials();
    test_textures();
    test_lights();
    test_cameras();
    test_glb_and_files();
    test_warnings();
    test_errors();
    test_mutations();
    return test_finish();
}
