/* gltf_builder.h: glTF test files built in memory for the loader tests: a growable byte
 * buffer, the standard buffer (a quad with normals, UVs, indices of every width and a sparse
 * accessor) with its views and accessors, complete JSON texts (single quotes in the templates,
 * turned into double quotes), GLB containers and PNG images written with libpng. Out of memory
 * aborts; results are malloc'd (the caller frees). */
#ifndef PC_TEST_GLTF_BUILDER_H
#define PC_TEST_GLTF_BUILDER_H

#include <stddef.h>
#include <stdint.h>

#include "renderer/gltf/gltf_loader.h"

typedef struct bin {
    uint8_t *p;
    size_t n, cap;
} bin;

extern const float kQuad[12];   /* the standard quad's positions */
extern const uint8_t kRgba[16]; /* a 2 x 2 RGBA test image */

void bin_raw(bin *b, const void *data, size_t n);
void bin_align(bin *b, uint8_t fill);
/* Appends at a 4-byte aligned offset and returns it. */
size_t bin_put(bin *b, const void *data, size_t n);
/* The standard buffer (188 bytes); positions NULL: kQuad. */
void std_bin(bin *b, const float *positions);

/* Views and accessors of the standard buffer, and a mesh using them. */
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
char *gltf_json(const bin *b, int glb, const char *views, const char *accessors, const char *rest);
/* GLB container: header, JSON chunk padded with spaces, BIN chunk (b may be NULL) padded with
 * zeros; *size gets its length. */
uint8_t *make_glb(const char *json, const bin *b, size_t *size);
/* A PNG of w x h pixels; color_type: PNG_COLOR_TYPE_*; rows packed, 16-bit samples big-endian. */
void make_png(bin *out, int w, int h, int color_type, int depth, const uint8_t *px);
/* "data:image/png;base64,..." */
char *png_data_uri(const bin *png);
/* A .glb of one quad drawn count times, each with a material of its own whose base colour is a
 * texture from an image of its own: pngs[i] as a data URI. pad zero bytes follow the standard
 * buffer in the BIN chunk (unused; they make the file that much larger). */
uint8_t *make_glb_images(const bin *pngs, int count, size_t pad, size_t *size);
/* A w x h one-channel 8-bit PNG of zeros: a few KiB for 64 Mi pixels. */
void make_flat_png(bin *out, int w, int h);

/* ---- whole test scenes ---- */
/* A closed furnace written as glTF: the inside of the cube [-1, 1]^3 (inward normals, single
 * sided), one metallic-roughness material of grey base colour `base` emitting `emission` (no
 * KHR extensions, so the dielectric specular of Appendix B applies), no lights, and a camera at
 * (0, 0, 0.5) looking down -Z. */
char *gltf_furnace(float base, float emission, float metallic, float roughness);

/* An rd_scene written as glTF (JSON with the buffer as a data URI): each mesh's triangles as
 * non-indexed primitives, one per material (POSITION and NORMAL, bit for bit), its materials as
 * metallic-roughness materials (emission above 1 through KHR_materials_emissive_strength; a
 * Lambertian builtin material becomes glTF's dielectric), its root nodes with their TRS or
 * matrix, its punctual lights (KHR_lights_punctual) and cameras placed by nodes of their own.
 * The scene must be updated (rd_scene_update) and have no child nodes; lights and cameras
 * placed by nodes are written at their world placement. */
char *gltf_from_scene(const rd_scene *s);

/* ---- loading and checking ---- */
extern char gltf_err[512]; /* the message of the last load_text */
/* Loads JSON text from memory (no base folder). */
rd_gltf_result load_text(const char *json, rd_scene *s);
int near3(const float *a, float x, float y, float z);
/* A scene left destroyed (zeroed) after a failed load. */
int scene_is_empty(const rd_scene *s);
int has_warning(const rd_scene *s, const char *needle);
/* Expects failure with `code` and a message containing `needle`; the scene must be empty. */
void expect_error(const char *json, rd_gltf_result code, const char *needle, int line);
#define EXPECT_ERROR(json, code, needle) expect_error(json, code, needle, __LINE__)

#endif
