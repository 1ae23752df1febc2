/* gltf_import.h: the C side of the glTF importer's building blocks — everything that works on
 * plain bytes and arrays: the GLB container and the loader's messages, the JSON nesting
 * pre-check, external files, image decoding, reading accessor elements, a primitive's
 * triangles, material factors, nodes, lights and an animation sampler's keys. gltf_convert.c
 * walks the parsed document (gltf_document.h) and calls these; gltf_loader.cpp (the one C++
 * file, which owns tinygltf) calls the container, file and image parts from tinygltf's
 * callbacks. Internal to the importer; the public API is gltf_loader.h.
 *
 * Errors: functions that can fail return an rd_gltf_result and write one sentence to err
 * (errlen > 0), the message the loader reports unchanged.
 */
#ifndef RD_GLTF_IMPORT_H
#define RD_GLTF_IMPORT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* glTF 2.0 enumerations (accessor.componentType, primitive.mode), as the specification
 * numbers them. */
enum {
    RD_GLTF_BYTE = 5120,
    RD_GLTF_UNSIGNED_BYTE = 5121,
    RD_GLTF_SHORT = 5122,
    RD_GLTF_UNSIGNED_SHORT = 5123,
    RD_GLTF_UNSIGNED_INT = 5125,
    RD_GLTF_FLOAT = 5126
};
enum { RD_GLTF_MODE_TRIANGLES = 4, RD_GLTF_MODE_TRIANGLE_STRIP = 5, RD_GLTF_MODE_TRIANGLE_FAN = 6 };

enum { RD_GLTF_MAX_JSON_DEPTH = 100, RD_GLTF_LABEL_MAX = 160 };

/* A string of the document: len bytes at s, which is '\0'-terminated (the text itself may hold
 * '\0' bytes). */
typedef struct rd_gltf_str {
    const char *s;
    size_t len;
} rd_gltf_str;

/* ---- container (gltf_container.c) --------------------------------------------------------- */

/* The JSON text and the BIN chunk's size of a .glb, or the whole input as JSON text. */
typedef struct rd_gltf_container {
    bool glb;
    const char *json;
    size_t json_size;
    size_t bin_size; /* 0: no BIN chunk */
} rd_gltf_container;

/* Splits data (GLB when it starts with "glTF", else JSON text) into its chunks, checking the
 * GLB header and chunk lengths. out points into data. */
rd_gltf_result rd_gltf_parse_container(const unsigned char *data, size_t size,
                                       rd_gltf_container *out, char *err, size_t errlen);
/* Refuses JSON text nesting deeper than RD_GLTF_MAX_JSON_DEPTH (tinygltf converts extras and
 * extensions recursively). */
rd_gltf_result rd_gltf_check_json_depth(const char *s, size_t n, char *err, size_t errlen);

/* ---- accessors (gltf_accessor.c) ----------------------------------------------------------- */

/* A validated accessor: element i lies at data + i * stride (or is zero when data is null),
 * unless sparse substitution applies (sparse_index increasing, below count). Borrows its
 * memory from the document. */
typedef struct rd_gltf_accessor {
    int index;
    const unsigned char *data;
    size_t stride, count, elem;
    int ctype, ncomp;
    bool normalized;
    const uint32_t *sparse_index;
    size_t sparse_count;
    const unsigned char *sparse_values;
} rd_gltf_accessor;

/* Bytes of one component of ctype (0: not a component type). */
size_t rd_gltf_component_size(int ctype);
/* Decodes and checks n sparse indices of component type ctype at p: each below count and
 * increasing. false: they are not. */
bool rd_gltf_read_sparse_indices(const unsigned char *p, int ctype, size_t n, size_t count,
                                 uint32_t *out);
/* Element i as floats (ncomp of them; normalized integers mapped as glTF 3.11 says). */
void rd_gltf_read_floats(const rd_gltf_accessor *a, size_t i, float *out);
/* Element i as unsigned integers (ncomp of them; JOINTS_n). */
void rd_gltf_read_uints(const rd_gltf_accessor *a, size_t i, uint32_t *out);
/* Element i of an index accessor. */
uint32_t rd_gltf_read_index(const rd_gltf_accessor *a, size_t i);

/* ---- meshes (gltf_mesh.c) ------------------------------------------------------------------ */

/* A morph target's validated accessors (index -1: the attribute is not given). */
typedef struct rd_gltf_target {
    rd_gltf_accessor pos, nrm, tan;
} rd_gltf_target;

/* A triangle primitive whose accessors were validated (counts agree, tris > 0). */
typedef struct rd_gltf_primitive {
    int mode; /* RD_GLTF_MODE_TRIANGLES, _STRIP or _FAN */
    rd_gltf_accessor pos, nrm, uv, tan, idx;
    bool has_nrm, has_uv, has_tan, has_idx;
    uint64_t tris;
    uint32_t material; /* rd material: glTF material + 1, 0 for none */
    /* skin and morph targets (gltf_skin.c): joint_sets pairs of JOINTS_n and WEIGHTS_n, and
     * target_count targets (malloc'd) */
    uint32_t joint_sets;
    rd_gltf_accessor joints[2], weights[2];
    rd_gltf_target *targets;
    size_t target_count;
} rd_gltf_primitive;

/* The vertex (accessor element) of corner k of triangle t of pr, through its indices when it has
 * them (not range-checked: rd_gltf_fill_mesh checks). */
size_t rd_gltf_corner_vertex(const rd_gltf_primitive *pr, uint64_t t, int k);

/* Fills out (made by rd_scene_add_mesh with the primitives' triangle count) with the
 * triangles of prims[0..n): positions (finite), normals (normalized, else the flat normal),
 * TANGENT where any primitive has them (zeros elsewhere), TEXCOORD_0 and materials. Fails on
 * an out-of-range index or a non-finite position; messages name glTF mesh `mesh` and the
 * position in prims. */
rd_gltf_result rd_gltf_fill_mesh(size_t mesh, const rd_gltf_primitive *prims, size_t n,
                                 rd_mesh *out, char *err, size_t errlen);

/* ---- animations (gltf_animation.c) --------------------------------------------------------- */

/* Reads an animation sampler's keys: in->count times (finite, >= 0, not decreasing) and
 * val->count values of `components` floats (finite) into times and values. where names the
 * sampler in messages. */
rd_gltf_result rd_gltf_read_keys(const char *where, const rd_gltf_accessor *in,
                                 const rd_gltf_accessor *val, uint32_t components, float *times,
                                 float *values, char *err, size_t errlen);

/* ---- materials (gltf_materials.c) ---------------------------------------------------------- */

/* A glTF material's factors as the document holds them (glTF defaults filled in). */
typedef struct rd_gltf_material_factors {
    const double *base_color; /* baseColorFactor */
    size_t base_color_count;
    const double *emissive; /* emissiveFactor */
    size_t emissive_count;
    bool has_strength;       /* KHR_materials_emissive_strength.emissiveStrength is present */
    bool strength_is_number; /* ... and a number */
    double strength;
    double alpha_cutoff;
    const char *alpha_mode; /* alpha_mode_len bytes, not terminated */
    size_t alpha_mode_len;
    bool double_sided;
    double metallic, roughness, normal_scale, occlusion_strength;
} rd_gltf_material_factors;

/* Material i's colour factors, emission (times its strength), alpha mode and cutoff into mt
 * (clamped as the specification's ranges say); warns on s about an unknown alphaMode. */
rd_gltf_result rd_gltf_material_colors(rd_scene *s, size_t i, const rd_gltf_material_factors *f,
                                       rd_material *mt, char *err, size_t errlen);
/* The core metallic-roughness factors beyond colour (metallic, roughness, normal scale,
 * occlusion strength), clamped; specular = 1 (the full Appendix B BRDF). */
rd_gltf_result rd_gltf_material_pbr(size_t i, const rd_gltf_material_factors *f, rd_material *mt,
                                    char *err, size_t errlen);
/* The file-wide material warnings: how many materials are BLEND. */
void rd_gltf_material_warnings(rd_scene *s, size_t blend);

/* The len bytes at s made safe for a message (which could end up in JSON or a terminal): at
 * most max bytes (4 <= max <= 127), longer text shortened with "...", control and non-ASCII
 * bytes replaced with '?'; out is terminated. */
void rd_gltf_clean(const char *s, size_t len, size_t max, char out[128]);
/* "mesh 3", or "mesh 3 'Cube'" when the name is not empty (cleaned, at most 64 bytes). */
void rd_gltf_label(const char *kind, size_t index, rd_gltf_str name, char out[RD_GLTF_LABEL_MAX]);
/* d as a finite float, false when it is not finite or out of float range. */
bool rd_gltf_to_float(double d, float *out);
/* calloc of n (at least 1) elements of size bytes; aborts when memory runs out (document-sized
 * arrays: the importer's other limits keep them small). */
void *rd_gltf_alloc(size_t n, size_t size);

/* ---- nodes (gltf_nodes.c) ------------------------------------------------------------------ */

/* A list of node indices as the document holds them (a node's children, a scene's roots). */
typedef struct rd_gltf_node_list {
    const int *nodes;
    size_t count;
} rd_gltf_node_list;

/* Checks the node hierarchy (children in range, one parent each, no cycle; the default scene
 * and its roots valid) and lists the nodes the shown scene reaches, parents first: the
 * default scene (scenes[0] when default_scene is -1), or every parentless node when the file
 * has no scene. parent[count] gets each node's parent (-1: none); order (count entries
 * allocated by the caller) the reachable nodes, *order_count how many. */
rd_gltf_result rd_gltf_hierarchy(size_t count, const rd_gltf_node_list *children,
                                 size_t scene_count, const rd_gltf_node_list *scenes,
                                 int default_scene, int *parent, size_t *order, size_t *order_count,
                                 char *err, size_t errlen);

/* A node's transform as the document holds it (empty arrays: not given). */
typedef struct rd_gltf_transform {
    const double *matrix, *translation, *rotation, *scale;
    size_t matrix_count, translation_count, rotation_count, scale_count;
} rd_gltf_transform;

/* Node index's matrix or TRS (glTF defaults where not given) into n; fails when a part has
 * the wrong length or a value is not finite. */
rd_gltf_result rd_gltf_node_transform(size_t index, const rd_gltf_transform *t, rd_node *n,
                                      char *err, size_t errlen);

/* ---- lights and cameras (gltf_lights.c) ---------------------------------------------------- */

/* A KHR_lights_punctual light as the document holds it. */
typedef struct rd_gltf_light_params {
    const char *type; /* type_len bytes, not terminated */
    size_t type_len;
    const double *color; /* color_count values; none: white */
    size_t color_count;
    double intensity, range, inner_cone, outer_cone;
} rd_gltf_light_params;

/* Light index's type, colour, intensity, range and spot cones into l (checked; a directional
 * light has no range). An unknown type is warned about on s and *ignored set. */
rd_gltf_result rd_gltf_light(rd_scene *s, size_t index, const rd_gltf_light_params *p, rd_light *l,
                             bool *ignored, char *err, size_t errlen);
/* Perspective camera index's yfov (0..pi), znear (> 0) and aspectRatio (>= 0; 0: the view's)
 * into c. */
rd_gltf_result rd_gltf_perspective(size_t index, double yfov, double znear, double aspect,
                                   rd_camera *c, char *err, size_t errlen);

/* ---- external files (gltf_uri.c) ------------------------------------------------------------ */

/* Where external URIs may be opened from. */
typedef struct rd_gltf_files {
    bool allowed; /* false: loading from memory without a base folder */
    char *base;   /* folder that external URIs resolve against */
    char *prefix; /* base with exactly one trailing '/' */
    size_t prefix_len;
    char last_refusal[256]; /* why the last path was refused ("" : none yet) */
    uint64_t bytes_in;      /* the file's own bytes, plus each external file read (buffers,
                               images): what rd_gltf_decode_limit scales with */
} rd_gltf_files;

/* base_dir NULL: no file may be opened; "" means ".". dispose frees what init allocated. */
void rd_gltf_files_init(rd_gltf_files *f, const char *base_dir);
void rd_gltf_files_dispose(rd_gltf_files *f);
/* Why the decoded relative URI rel (len bytes, rel[len] == '\0') may not be opened, or NULL
 * when it may. */
const char *rd_gltf_uri_refusal(const rd_gltf_files *f, const char *rel, size_t len);
/* tinygltf's file callbacks get JoinPath(base, uri): true when path is the prefix followed by
 * a URI that may be opened (*rel: where that URI starts); else records why in last_refusal. */
bool rd_gltf_files_check_path(rd_gltf_files *f, const char *path, size_t len, size_t *rel);
/* tinygltf's FileExists: check_path passes and path names a regular file. */
bool rd_gltf_files_exists(rd_gltf_files *f, const char *path, size_t len);
/* prefix + rel, malloc'd (the caller frees). */
char *rd_gltf_files_join(const rd_gltf_files *f, const char *rel, size_t len);
/* strerror text of e. */
void rd_gltf_errno_text(int e, char *out, size_t outlen);

typedef enum rd_gltf_read_status {
    RD_GLTF_READ_OK = 0,
    RD_GLTF_READ_FAILED,    /* why says what went wrong */
    RD_GLTF_READ_TOO_LARGE, /* larger than max_size (why says how large) */
    RD_GLTF_READ_NO_MEMORY  /* alloc returned NULL */
} rd_gltf_read_status;

/* Reads the whole regular file at path (never a FIFO or a device) into alloc(user, size),
 * which returns size bytes owned by the caller (NULL: out of memory, unless size is 0). */
rd_gltf_read_status rd_gltf_read_file(const char *path, uint64_t max_size,
                                      unsigned char *(*alloc)(void *user, size_t size), void *user,
                                      char *why, size_t whylen);

/* The whole file at path into *data (malloc'd, *size bytes; NULL on failure). */
rd_gltf_read_status rd_gltf_read_file_malloc(const char *path, uint64_t max_size,
                                             unsigned char **data, size_t *size, char *why,
                                             size_t whylen);

/* ---- images (gltf_image.c) ---------------------------------------------------------------------
 */

/* Decodes a PNG or JPEG image to w x h 8-bit RGBA pixels (malloc'd; the caller frees) and adds
 * their size to *decoded_bytes, or returns NULL with *code and why saying what is wrong (too
 * large alone, or with the images decoded before beyond rd_gltf_decode_limit(bytes_in), or not
 * decodable). Sizes are read from the image's header before anything is decoded. */
unsigned char *rd_gltf_decode_image(uint64_t *decoded_bytes, uint64_t bytes_in,
                                    const unsigned char *bytes, size_t size, int *w, int *h,
                                    rd_gltf_result *code, char *why, size_t whylen);

/* The loader's final message: len bytes of msg as one readable line in err (at most errlen - 1
 * bytes, control and non-ASCII bytes replaced with '?'; messages may end up in JSON or logs). */
void rd_gltf_write_text(const char *msg, size_t len, char *err, size_t errlen);

/* Writes one message to err (errlen > 0) and returns code. */
rd_gltf_result rd_gltf_fail(char *err, size_t errlen, rd_gltf_result code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

#ifdef __cplusplus
}
#endif

#endif
