/* gltf_document.h: a parsed glTF 2.0 document as plain C arrays — what gltf_loader.cpp copies
 * out of tinygltf's model (values unchecked: indices may be out of range, -1 means "not
 * given") and what gltf_convert.c turns into an rd_scene. Every pointer borrows from the
 * loader's model, which outlives the conversion. Internal to the importer.
 */
#ifndef RD_GLTF_DOCUMENT_H
#define RD_GLTF_DOCUMENT_H

#include "renderer/gltf/gltf_import.h"

#ifdef __cplusplus
extern "C" {
#endif

/* accessor.type, sampler and primitive enumerations as tinygltf numbers them. */
enum {
    RD_GLTF_TYPE_VEC2 = 2,
    RD_GLTF_TYPE_VEC3 = 3,
    RD_GLTF_TYPE_VEC4 = 4,
    RD_GLTF_TYPE_MAT2 = 34,
    RD_GLTF_TYPE_MAT3 = 35,
    RD_GLTF_TYPE_MAT4 = 36,
    RD_GLTF_TYPE_SCALAR = 65
};
enum { RD_GLTF_WRAP_REPEAT = 10497, RD_GLTF_WRAP_CLAMP = 33071, RD_GLTF_WRAP_MIRROR = 33648 };
enum { RD_GLTF_FILTER_NEAREST = 9728, RD_GLTF_MODE_LINE_STRIP = 3 };

typedef struct rd_gltf_doc_buffer_view {
    int buffer;
    size_t byte_offset, byte_length, byte_stride;
} rd_gltf_doc_buffer_view;

typedef struct rd_gltf_doc_accessor {
    int buffer_view;
    size_t byte_offset;
    bool normalized;
    int component_type, type; /* RD_GLTF_FLOAT ..., RD_GLTF_TYPE_* (others: MAT2 ...) */
    size_t count;
    bool sparse;
    int sparse_count;
    int sparse_index_view, sparse_index_offset, sparse_index_type;
    int sparse_value_view, sparse_value_offset;
} rd_gltf_doc_accessor;

typedef struct rd_gltf_doc_image {
    rd_gltf_str name, uri;
    rd_gltf_str rel;           /* uri percent-decoded (empty for a data: URI) */
    const unsigned char *rgba; /* decoded while parsing (rgba_size bytes), or NULL */
    size_t rgba_size;
    int width, height;
    bool failed; /* decoding while parsing failed: */
    rd_gltf_result failure;
    const char *why;
} rd_gltf_doc_image;

typedef struct rd_gltf_doc_texture {
    int source, sampler;
} rd_gltf_doc_texture;

typedef struct rd_gltf_doc_sampler {
    int wrap_s, wrap_t, mag_filter;
} rd_gltf_doc_sampler;

typedef struct rd_gltf_texture_ref {
    int index, tex_coord;
} rd_gltf_texture_ref;

typedef struct rd_gltf_doc_material {
    const char *name; /* NULL: none */
    rd_gltf_material_factors factors;
    rd_gltf_texture_ref base_color, emissive, metallic_roughness, normal, occlusion;
    const rd_gltf_str *extensions; /* names, sorted */
    size_t extension_count;
} rd_gltf_doc_material;

/* A morph target's attribute accessors (-1: not given). */
typedef struct rd_gltf_doc_target {
    int pos, nrm, tan; /* POSITION, NORMAL, TANGENT */
} rd_gltf_doc_target;

typedef struct rd_gltf_doc_primitive {
    int mode, indices, material;
    bool has_pos, has_nrm, has_uv, has_tan; /* POSITION, NORMAL, TEXCOORD_0, TANGENT */
    int pos, nrm, uv, tan;
    int joints[2], weights[2]; /* JOINTS_0/_1, WEIGHTS_0/_1 (-1: not given) */
    const rd_gltf_doc_target *targets;
    size_t target_count;
} rd_gltf_doc_primitive;

typedef struct rd_gltf_doc_mesh {
    rd_gltf_str name;
    const rd_gltf_doc_primitive *primitives;
    size_t primitive_count;
    const double *weights; /* default morph weights */
    size_t weight_count;
} rd_gltf_doc_mesh;

typedef struct rd_gltf_doc_skin {
    rd_gltf_str name;
    const int *joints;
    size_t joint_count;
    int inverse_bind; /* accessor, -1: identities */
} rd_gltf_doc_skin;

typedef struct rd_gltf_doc_node {
    rd_gltf_str name;
    int mesh, camera;
    bool has_light;    /* KHR_lights_punctual present */
    bool light_is_int; /* ... and its light is an integer: */
    int light;
    rd_gltf_transform transform;
    int skin;              /* -1: none */
    const double *weights; /* morph weights overriding the mesh's */
    size_t weight_count;
} rd_gltf_doc_node;

typedef struct rd_gltf_doc_camera {
    rd_gltf_str name, type;
    double yfov, znear, aspect;
} rd_gltf_doc_camera;

typedef struct rd_gltf_doc_light {
    const char *name; /* NULL: none */
    rd_gltf_light_params params;
} rd_gltf_doc_light;

typedef struct rd_gltf_doc_channel {
    int sampler, node;
    rd_gltf_str path;
} rd_gltf_doc_channel;

typedef struct rd_gltf_doc_anim_sampler {
    int input, output;
    rd_gltf_str interpolation;
} rd_gltf_doc_anim_sampler;

typedef struct rd_gltf_doc_animation {
    rd_gltf_str name;
    const rd_gltf_doc_channel *channels;
    size_t channel_count;
    const rd_gltf_doc_anim_sampler *samplers;
    size_t sampler_count;
} rd_gltf_doc_animation;

typedef struct rd_gltf_document {
    const rd_gltf_str *extensions_used;
    size_t extensions_used_count;
    const rd_gltf_doc_skin *skins;
    size_t skin_count;
    int default_scene;
    const rd_gltf_str *buffers; /* buffer data (s may be NULL when len is 0) */
    size_t buffer_count;
    const rd_gltf_doc_buffer_view *views;
    size_t view_count;
    const rd_gltf_doc_accessor *accessors;
    size_t accessor_count;
    const rd_gltf_doc_image *images;
    size_t image_count;
    const rd_gltf_doc_texture *textures;
    size_t texture_count;
    const rd_gltf_doc_sampler *samplers;
    size_t sampler_count;
    const rd_gltf_doc_material *materials;
    size_t material_count;
    const rd_gltf_doc_mesh *meshes;
    size_t mesh_count;
    const rd_gltf_doc_node *nodes;
    const rd_gltf_node_list *children; /* of each node */
    size_t node_count;
    const rd_gltf_node_list *scenes; /* root nodes of each scene */
    size_t scene_count;
    const rd_gltf_doc_camera *cameras;
    size_t camera_count;
    const rd_gltf_doc_light *lights;
    size_t light_count;
    const rd_gltf_doc_animation *animations;
    size_t animation_count;
} rd_gltf_document;

/* ---- the JSON pre-scan (gltf_prescan.c) ------------------------------------------------------ */

/* A member that should be an unsigned integer. */
typedef struct rd_gltf_scan_uint {
    bool present, is_uint;
    uint64_t value;
} rd_gltf_scan_uint;

typedef struct rd_gltf_scan_buffer {
    bool is_object;
    rd_gltf_scan_uint byte_length;
    bool has_uri; /* uri is present and a string: */
    rd_gltf_str uri;
    long long data_size; /* bytes its data: URI decodes to (as tinygltf decodes); -1: not one */
    rd_gltf_str rel;     /* not a data: URI: uri percent-decoded */
} rd_gltf_scan_buffer;

typedef struct rd_gltf_scan_view {
    bool is_object;
    rd_gltf_scan_uint buffer, byte_offset, byte_length;
} rd_gltf_scan_view;

typedef struct rd_gltf_scan_image {
    bool is_object, has_view;
    rd_gltf_scan_uint view; /* bufferView */
} rd_gltf_scan_image;

/* What the pre-scan reads of the JSON (an object) before tinygltf parses it. */
typedef struct rd_gltf_scan {
    bool has_version; /* asset is an object holding a string version: */
    rd_gltf_str version;
    bool has_required, required_is_array; /* extensionsRequired */
    const rd_gltf_str *required;          /* s NULL: not a string */
    size_t required_count;
    bool not_array[3]; /* buffers, bufferViews, images present but not arrays */
    const rd_gltf_scan_buffer *buffers;
    size_t buffer_count;
    const rd_gltf_scan_view *views;
    size_t view_count;
    const rd_gltf_scan_image *images;
    size_t image_count;
} rd_gltf_scan;

/* Checks, in this order, the asset version, extensionsRequired, that buffers, bufferViews and
 * images are arrays, each buffer's byteLength against its data (data: URI, GLB BIN chunk of c
 * or external file under files), each view's range inside its buffer and each image's view
 * (at most 2 GiB, which tinygltf hands to the image callback as an int). */
rd_gltf_result rd_gltf_prescan(const rd_gltf_scan *s, const rd_gltf_container *c,
                               const rd_gltf_files *files, char *err, size_t errlen);

/* The extensions the importer implements (KHR_lights_punctual, KHR_materials_emissive_strength):
 * a file may require them, and they draw no "not supported" warning. */
bool rd_gltf_extension_supported(const char *name, size_t len);

/* Or'ed into rd_gltf_resolve_accessor's type: integer components that are not normalized are
 * allowed (JOINTS_n, read with rd_gltf_read_uints). */
#define RD_GLTF_INTEGERS 0x10000

/* Resolves accessor index of d for use as `what` (in messages): its type must be `type` and its
 * component type one of ctypes (integers other than SCALAR must be normalized); its elements (and
 * sparse parts) must lie inside their buffer views. On success c may own sparse indices:
 * rd_gltf_accessor_dispose frees them. */
rd_gltf_result rd_gltf_resolve_accessor(const rd_gltf_document *d, int index, const char *what,
                                        int type, const int *ctypes, size_t nctypes,
                                        rd_gltf_accessor *c, char *err, size_t errlen);
void rd_gltf_accessor_dispose(rd_gltf_accessor *a);

/* The state of one conversion (gltf_convert.c), shared with its parts. */
typedef struct rd_gltf_conv {
    const rd_gltf_document *doc;
    rd_gltf_files *files;
    uint64_t *decoded_bytes;
    rd_scene *s;
    int32_t *node_map;    /* glTF node -> rd node (-1: not in the scene) */
    int32_t *tex_map;     /* glTF texture -> rd texture (-1: not added yet) */
    uint64_t anim_floats; /* animation times and values kept so far */
    char *err;
    size_t errlen;
    uint64_t deform_floats;      /* skin and morph target values kept so far (gltf_skin.c) */
    uint64_t weights_normalised; /* skinned triangle corners whose weights did not sum to one */
    uint64_t tris_left; /* triangles the scene may still take (copies of deforming meshes) */
} rd_gltf_conv;

/* Texture index of material `material` read through TEXCOORD_tex_coord as its `slot` texture:
 * *out gets the rd texture (added on first use: decoded, external files read) or -1 when
 * index is -1 or the texture is ignored with a warning (gltf_textures.c). */
rd_gltf_result rd_gltf_conv_texture(rd_gltf_conv *c, rd_gltf_texture_ref ref, size_t material,
                                    const char *slot, int32_t *out);
/* The document's node animations (gltf_animation.c). */
rd_gltf_result rd_gltf_conv_animations(rd_gltf_conv *c);
/* A primitive's JOINTS_n/WEIGHTS_n and morph targets resolved into pr (gltf_skin.c), after its
 * POSITION; rd_gltf_primitive_deform_dispose frees what they hold. */
rd_gltf_result rd_gltf_plan_deform(const rd_gltf_document *d, const rd_gltf_doc_primitive *gp,
                                   const char *where, rd_gltf_primitive *pr, char *err,
                                   size_t errlen);
void rd_gltf_primitive_deform_dispose(rd_gltf_primitive *pr);
/* After rd_gltf_fill_mesh: gives out (glTF mesh `mesh`, primitives prims[0..n)) its deformation
 * when a primitive has joints or morph targets: per-vertex joints and weights (normalised, the
 * triangle corners that needed it counted in c->weights_normalised), target deltas, default weights
 * and the rest shape. Fails on bad weights, deltas or counts, and past a memory limit. */
rd_gltf_result rd_gltf_fill_deform(rd_gltf_conv *c, size_t mesh, const rd_gltf_primitive *prims,
                                   size_t n, rd_mesh *out);
/* The document's skins (gltf_skin.c), after the nodes: each skin the shown nodes use, with its
 * joints mapped to rd nodes and its inverse bind matrices; the nodes get their skin and morph
 * weights, checked against their meshes (mesh_map: glTF mesh -> rd mesh), and every node after
 * the first that deforms a mesh gets a copy of it. */
rd_gltf_result rd_gltf_conv_skins(rd_gltf_conv *c, const int32_t *mesh_map);

/* Converts doc into s (rd_scene_update done): checks every index, accessor range and value
 * before reading a byte, decodes and reads external images through files (counting decoded
 * bytes in *decoded_bytes) and refuses more than max_triangles triangles. On failure s holds
 * a partial scene for the caller to destroy. */
rd_gltf_result rd_gltf_convert(const rd_gltf_document *doc, rd_gltf_files *files,
                               uint64_t *decoded_bytes, uint64_t max_triangles, rd_scene *s,
                               char *err, size_t errlen);

#ifdef __cplusplus
}
#endif

#endif
