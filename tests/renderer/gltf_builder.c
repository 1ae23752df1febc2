/* gltf_builder.c: glTF test files built in memory (see gltf_builder.h). */
#include "gltf_builder.h"

#include <assert.h>
#include <math.h>
#include <png.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/xform.h"
#include "test_util.h"

/* ---- byte and string builders ---------------------------------------------------------- */

void bin_raw(bin *b, const void *data, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = realloc(b->p, b->cap);
    }
    if (n) memcpy(b->p + b->n, data, n);
    b->n += n;
}

void bin_align(bin *b, uint8_t fill)
{
    while (b->n % 4)
        bin_raw(b, &fill, 1);
}

/* Appends at a 4-byte aligned offset and returns it. */
size_t bin_put(bin *b, const void *data, size_t n)
{
    bin_align(b, 0);
    size_t at = b->n;
    bin_raw(b, data, n);
    return at;
}

/* ---- the standard buffer ----------------------------------------------------------------
 * A unit quad in the XY plane: 4 positions (0) 4 normals (48) 4 uvs (96), indices 0 1 2 0 2 3
 * as u16 (128) u8 (140) u32 (148), then a sparse index (172) and a sparse value (176). */
const uint8_t kRgba[16] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 255, 255, 255, 0};
const float kQuad[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

void std_bin(bin *b, const float *positions)
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

/* A complete glTF JSON text (double quotes). b: buffer 0; glb: no URI (GLB BIN chunk);
 * views/accessors: array items or NULL for the standard ones; rest: more top-level members. */
char *gltf_json(const bin *b, int glb, const char *views, const char *accessors, const char *rest)
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
uint8_t *make_glb(const char *json, const bin *b, size_t *size)
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
void make_png(bin *out, int w, int h, int color_type, int depth, const uint8_t *px)
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

char *png_data_uri(const bin *png)
{
    char *b64 = test_base64(png->p, png->n);
    char *uri = test_xprintf("data:image/png;base64,%s", b64);
    free(b64);
    return uri;
}

/* ---- loading and checking -------------------------------------------------------------------- */

char gltf_err[512];

rd_gltf_result load_text(const char *json, rd_scene *s)
{
    gltf_err[0] = '\0';
    return rd_gltf_load_memory(json, strlen(json), NULL, NULL, s, gltf_err, sizeof gltf_err);
}

int near3(const float *a, float x, float y, float z)
{
    return fabsf(a[0] - x) < 1e-5f && fabsf(a[1] - y) < 1e-5f && fabsf(a[2] - z) < 1e-5f;
}

int scene_is_empty(const rd_scene *s)
{
    return s->meshes == NULL && s->mesh_count == 0 && s->materials == NULL &&
           s->material_count == 0 && s->nodes == NULL && s->warnings == NULL &&
           s->warning_count == 0 && s->textures == NULL;
}

int has_warning(const rd_scene *s, const char *needle)
{
    for (uint32_t i = 0; i < s->warning_count; i++)
        if (strstr(s->warnings[i], needle)) return 1;
    return 0;
}

/* Expects failure with `code` and a message containing `needle`; the scene must be empty. */
void expect_error(const char *json, rd_gltf_result code, const char *needle, int line)
{
    rd_scene s;
    rd_gltf_result r = load_text(json, &s);
    CHECKF(r == code, "line %d: got %s (%s), wanted %s", line, rd_gltf_strerror(r), gltf_err,
           rd_gltf_strerror(code));
    CHECKF(strstr(gltf_err, needle) != NULL, "line %d: message '%s' lacks '%s'", line, gltf_err,
           needle);
    CHECKF(scene_is_empty(&s), "line %d: scene not empty after an error", line);
    rd_scene_destroy(&s);
}

/* ---- whole test scenes ------------------------------------------------------------------ */

char *gltf_furnace(float base, float emission, float metallic, float roughness)
{
    /* six inward faces of the cube [-1, 1]^3, four vertices each, normals toward the centre */
    float pos[24 * 3], nrm[24 * 3];
    uint16_t idx[36];
    for (int f = 0; f < 6; f++) {
        int axis = f / 2;
        float side = f % 2 ? 1.0f : -1.0f; /* the face lies at axis = side, faces -side */
        int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const float cu[4] = {-1, 1, 1, -1}, cv[4] = {-1, -1, 1, 1};
        for (int k = 0; k < 4; k++) {
            float *p = pos + 3 * (4 * f + k), *n = nrm + 3 * (4 * f + k);
            p[axis] = side, p[u] = cu[k], p[v] = cv[k];
            n[0] = n[1] = n[2] = 0, n[axis] = -side;
        }
        /* (u, v) is counter-clockwise seen from +axis: flip the winding for the +side face so
         * every triangle's front faces the centre */
        static const uint16_t ccw[6] = {0, 1, 2, 0, 2, 3}, cw[6] = {0, 2, 1, 0, 3, 2};
        for (int k = 0; k < 6; k++)
            idx[6 * f + k] = (uint16_t)(4 * f + (side > 0 ? cw : ccw)[k]);
    }
    bin b = {0};
    size_t op = bin_put(&b, pos, sizeof pos), on = bin_put(&b, nrm, sizeof nrm),
           oi = bin_put(&b, idx, sizeof idx);
    char *views = test_xprintf("{'buffer':0,'byteOffset':%zu,'byteLength':%zu},"
                               "{'buffer':0,'byteOffset':%zu,'byteLength':%zu},"
                               "{'buffer':0,'byteOffset':%zu,'byteLength':%zu}",
                               op, sizeof pos, on, sizeof nrm, oi, sizeof idx);
    const char *acc = "{'bufferView':0,'componentType':5126,'count':24,'type':'VEC3',"
                      "'min':[-1,-1,-1],'max':[1,1,1]},"
                      "{'bufferView':1,'componentType':5126,'count':24,'type':'VEC3'},"
                      "{'bufferView':2,'componentType':5123,'count':36,'type':'SCALAR'}";
    char *rest = test_xprintf(
        "'materials':[{'pbrMetallicRoughness':{'baseColorFactor':[%g,%g,%g,1],"
        "'metallicFactor':%g,'roughnessFactor':%g},'emissiveFactor':[%g,%g,%g]}],"
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1},'indices':2,"
        "'material':0}]}],"
        "'cameras':[{'type':'perspective','perspective':{'yfov':1.0472,'znear':0.01}}],"
        "'nodes':[{'mesh':0},{'camera':0,'translation':[0,0,0.5]}],"
        "'scenes':[{'nodes':[0,1]}],'scene':0",
        base, base, base, metallic, roughness, emission, emission, emission);
    char *j = gltf_json(&b, 0, views, acc, rest);
    free(views);
    free(rest);
    free(b.p);
    return j;
}

/* A growing JSON text (single quotes, as gltf_json takes it). */
typedef struct text {
    char *p;
    size_t n;
} text;

static void text_add(text *t, char *piece) /* takes piece */
{
    size_t k = strlen(piece);
    t->p = realloc(t->p, t->n + k + 1);
    memcpy(t->p + t->n, piece, k + 1);
    t->n += k;
    free(piece);
}

/* Quaternion (x, y, z, w) of the rotation that takes a node's -Z to forward and +Y to up
 * (glTF cameras and lights look along -Z). */
static void look_quat(const float fwd[3], const float up_hint[3], float q[4])
{
    float f[3], r[3], u[3];
    rd_vec3_normalize(f, fwd, (const float[3]){0, 0, -1});
    rd_vec3_cross(r, f, up_hint);
    if (!(rd_vec3_length(r) > 1e-6f)) rd_vec3_cross(r, f, (const float[3]){1, 0, 0});
    rd_vec3_normalize(r, r, (const float[3]){1, 0, 0});
    rd_vec3_cross(u, r, f);
    const float cols[3][3] = {{r[0], r[1], r[2]}, {u[0], u[1], u[2]}, {-f[0], -f[1], -f[2]}};
    rd_mat3_cols_to_quat(cols, q);
}

char *gltf_from_scene(const rd_scene *s)
{
    bin b = {0};
    text views = {0}, acc = {0}, meshes = {0}, mats = {0}, nodes = {0}, lights = {0}, cams = {0};
    uint32_t view_count = 0, node_count = 0;
    text roots = {0};
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        text prims = {0};
        for (uint32_t mat = 0; mat < s->material_count; mat++) {
            uint32_t n = 0;
            for (uint32_t i = 0; i < mesh->tri_count; i++)
                n += mesh->material[i] == mat;
            if (!n) continue;
            float *pos = malloc(n * 9 * sizeof(float)), *nrm = malloc(n * 9 * sizeof(float));
            float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            uint32_t k = 0;
            for (uint32_t i = 0; i < mesh->tri_count; i++) {
                if (mesh->material[i] != mat) continue;
                memcpy(pos + 9 * k, mesh->positions + 9 * i, 9 * sizeof(float));
                memcpy(nrm + 9 * k, mesh->normals + 9 * i, 9 * sizeof(float));
                for (int v = 0; v < 9; v++) {
                    lo[v % 3] = fminf(lo[v % 3], pos[9 * k + v]);
                    hi[v % 3] = fmaxf(hi[v % 3], pos[9 * k + v]);
                }
                k++;
            }
            size_t op = bin_put(&b, pos, n * 9 * sizeof(float));
            size_t on = bin_put(&b, nrm, n * 9 * sizeof(float));
            free(pos);
            free(nrm);
            text_add(&views,
                     test_xprintf("%s{'buffer':0,'byteOffset':%zu,'byteLength':%zu},"
                                  "{'buffer':0,'byteOffset':%zu,'byteLength':%zu}",
                                  view_count ? "," : "", op, (size_t)n * 36, on, (size_t)n * 36));
            text_add(&acc, test_xprintf(
                               "%s{'bufferView':%u,'componentType':5126,'count':%u,'type':'VEC3',"
                               "'min':[%.9g,%.9g,%.9g],'max':[%.9g,%.9g,%.9g]},"
                               "{'bufferView':%u,'componentType':5126,'count':%u,'type':'VEC3'}",
                               view_count ? "," : "", view_count, 3 * n, lo[0], lo[1], lo[2], hi[0],
                               hi[1], hi[2], view_count + 1, 3 * n));
            text_add(&prims, test_xprintf("%s{'attributes':{'POSITION':%u,'NORMAL':%u},"
                                          "'material':%u}",
                                          prims.n ? "," : "", view_count, view_count + 1, mat));
            view_count += 2;
        }
        text_add(&meshes,
                 test_xprintf("%s{'primitives':[%s]}", m ? "," : "", prims.p ? prims.p : ""));
        free(prims.p);
    }
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rd_material *m = &s->materials[i];
        float e = fmaxf(m->emission[0], fmaxf(m->emission[1], m->emission[2]));
        float k = e > 1 ? 1 / e : 1;
        char *strength = e > 1 ? test_xprintf(",'extensions':{'KHR_materials_emissive_strength':"
                                              "{'emissiveStrength':%.9g}}",
                                              e)
                               : test_xprintf("%s", "");
        text_add(&mats,
                 test_xprintf("%s{'pbrMetallicRoughness':{'baseColorFactor':[%.9g,%.9g,%.9g,%.9g],"
                              "'metallicFactor':%.9g,'roughnessFactor':%.9g},"
                              "'emissiveFactor':[%.9g,%.9g,%.9g],'doubleSided':%s%s}",
                              i ? "," : "", m->base_color[0], m->base_color[1], m->base_color[2],
                              m->base_color[3], m->metallic, m->roughness, m->emission[0] * k,
                              m->emission[1] * k, m->emission[2] * k,
                              m->double_sided ? "true" : "false", strength));
        free(strength);
    }
    for (uint32_t i = 0; i < s->node_count; i++) {
        const rd_node *n = &s->nodes[i];
        assert(n->parent < 0);
        char *place = n->has_matrix
                          ? test_xprintf("'matrix':[%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,"
                                         "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g]",
                                         n->matrix[0], n->matrix[1], n->matrix[2], n->matrix[3],
                                         n->matrix[4], n->matrix[5], n->matrix[6], n->matrix[7],
                                         n->matrix[8], n->matrix[9], n->matrix[10], n->matrix[11],
                                         n->matrix[12], n->matrix[13], n->matrix[14], n->matrix[15])
                          : test_xprintf("'translation':[%.9g,%.9g,%.9g],'rotation':[%.9g,%.9g,"
                                         "%.9g,%.9g],'scale':[%.9g,%.9g,%.9g]",
                                         n->translation[0], n->translation[1], n->translation[2],
                                         n->rotation[0], n->rotation[1], n->rotation[2],
                                         n->rotation[3], n->scale[0], n->scale[1], n->scale[2]);
        char *mesh = n->mesh >= 0 ? test_xprintf("'mesh':%d,", n->mesh) : test_xprintf("%s", "");
        text_add(&nodes, test_xprintf("%s{%s%s}", node_count ? "," : "", mesh, place));
        text_add(&roots, test_xprintf("%s%u", node_count ? "," : "", node_count));
        node_count++;
        free(mesh);
        free(place);
    }
    static const char *const kLightType[] = {"point", "spot", "directional"};
    for (uint32_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        char *range =
            l->range > 0 ? test_xprintf(",'range':%.9g", l->range) : test_xprintf("%s", "");
        char *spot = l->type == RD_LIGHT_SPOT
                         ? test_xprintf(",'spot':{'innerConeAngle':%.9g,'outerConeAngle':%.9g}",
                                        l->inner_cone, l->outer_cone)
                         : test_xprintf("%s", "");
        text_add(&lights,
                 test_xprintf("%s{'type':'%s','color':[%.9g,%.9g,%.9g],'intensity':%.9g%s%s}",
                              i ? "," : "", kLightType[l->type], l->color[0], l->color[1],
                              l->color[2], l->intensity, range, spot));
        free(range);
        free(spot);
        float q[4];
        look_quat(l->direction, (const float[3]){0, 1, 0}, q);
        text_add(&nodes,
                 test_xprintf("%s{'translation':[%.9g,%.9g,%.9g],'rotation':[%.9g,%.9g,"
                              "%.9g,%.9g],'extensions':{'KHR_lights_punctual':{'light':%u}}}",
                              node_count ? "," : "", l->position[0], l->position[1], l->position[2],
                              q[0], q[1], q[2], q[3], i));
        text_add(&roots, test_xprintf("%s%u", node_count ? "," : "", node_count));
        node_count++;
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const rd_camera *c = &s->cameras[i];
        text_add(&cams, test_xprintf("%s{'type':'perspective','perspective':{'yfov':%.9g,"
                                     "'znear':%.9g}}",
                                     i ? "," : "", c->yfov, c->znear > 0 ? c->znear : 0.01f));
        float q[4];
        look_quat(c->forward, c->up, q);
        text_add(&nodes, test_xprintf("%s{'camera':%u,'translation':[%.9g,%.9g,%.9g],"
                                      "'rotation':[%.9g,%.9g,%.9g,%.9g]}",
                                      node_count ? "," : "", i, c->position[0], c->position[1],
                                      c->position[2], q[0], q[1], q[2], q[3]));
        text_add(&roots, test_xprintf("%s%u", node_count ? "," : "", node_count));
        node_count++;
    }
    char *light_ext =
        s->light_count
            ? test_xprintf(",'extensions':{'KHR_lights_punctual':{'lights':[%s]}}", lights.p)
            : test_xprintf("%s", "");
    char *cam_list =
        s->camera_count ? test_xprintf(",'cameras':[%s]", cams.p) : test_xprintf("%s", "");
    char *rest = test_xprintf(
        "'extensionsUsed':['KHR_lights_punctual','KHR_materials_emissive_strength'],"
        "'materials':[%s],'meshes':[%s],'nodes':[%s],'scenes':[{'nodes':[%s]}],'scene':0%s%s",
        mats.p ? mats.p : "", meshes.p ? meshes.p : "", nodes.p ? nodes.p : "",
        roots.p ? roots.p : "", cam_list, light_ext);
    char *j = gltf_json(&b, 0, views.p ? views.p : "", acc.p ? acc.p : "", rest);
    free(rest), free(cam_list), free(light_ext);
    free(views.p), free(acc.p), free(meshes.p), free(mats.p), free(nodes.p), free(lights.p);
    free(cams.p), free(roots.p), free(b.p);
    return j;
}

uint8_t *make_glb_images(const bin *pngs, int count, size_t pad, size_t *size)
{
    bin b;
    std_bin(&b, NULL);
    for (size_t i = 0; i < pad; i++) bin_raw(&b, "", 1);
    const int copies = count;
    size_t cap = 256;
    for (int i = 0; i < count; i++) cap += pngs[i].n * 4 / 3 + 512;
    char *rest = malloc(cap);
    if (!rest) abort();
    size_t n = 0;
#define PUT(...) n += (size_t)snprintf(rest + n, cap - n, __VA_ARGS__)
    PUT("'images':[");
    for (int i = 0; i < count; i++) {
        char *uri = png_data_uri(&pngs[i]);
        PUT("%s{'uri':'%s'}", i ? "," : "", uri);
        free(uri);
    }
    PUT("],'textures':[");
    for (int i = 0; i < copies; i++) PUT("%s{'source':%d}", i ? "," : "", i);
    PUT("],'materials':[");
    for (int i = 0; i < copies; i++)
        PUT("%s{'pbrMetallicRoughness':{'baseColorTexture':{'index':%d}}}", i ? "," : "", i);
    PUT("],'meshes':[{'primitives':[");
    for (int i = 0; i < copies; i++)
        PUT("%s{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2},'indices':3,'material':%d}",
            i ? "," : "", i);
    PUT("]}],'nodes':[{'mesh':0}],'scenes':[{'nodes':[0]}]");
#undef PUT
    char *j = gltf_json(&b, 1, NULL, NULL, rest);
    uint8_t *glb = make_glb(j, &b, size);
    free(j);
    free(rest);
    free(b.p);
    return glb;
}

void make_flat_png(bin *out, int w, int h)
{
    uint8_t *px = calloc((size_t)w * (size_t)h, 1);
    if (!px) abort();
    make_png(out, w, h, PNG_COLOR_TYPE_GRAY, 8, px);
    free(px);
}
