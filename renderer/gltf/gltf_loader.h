/* gltf_loader.h: glTF 2.0 (.gltf and .glb) to rd_scene.
 *
 * Input is untrusted: every index, size and value is validated before it is used, and any
 * failure is reported as a result code plus one human sentence, never a crash (only
 * out-of-memory aborts). Loading from memory never touches the file system unless a base
 * directory is given, and then only files below it (no absolute URIs, no ".." components).
 *
 * Materials: glTF 2.0 metallic-roughness (base colour, metallic, roughness, emission with
 * KHR_materials_emissive_strength, metallicRoughnessTexture, normalTexture with scale,
 * occlusionTexture with strength), rendered with the specification's Appendix B BRDF.
 * What is approximated or ignored, each reported in rd_scene.warnings:
 *   - textures read through TEXCOORD_n with n != 0 are ignored (only TEXCOORD_0 is loaded);
 *   - alphaMode BLEND is drawn opaque (no transparency, no coverage); MASK cuts out texels
 *     below alphaCutoff for every ray type;
 *   - other material extensions (KHR_materials_transmission, clearcoat, sheen, volume, ior,
 *     specular, ...) are ignored: one warning per extension, naming how many materials use it.
 * Primitives without a material use materials[0] (scene.h), a white Lambertian, not the
 * specification's default (metallic 1, roughness 1). TANGENT attributes are kept (scene.h
 * rd_mesh.tangents); without them the renderer derives tangents from the UVs per triangle.
 */
#ifndef RD_GLTF_LOADER_H
#define RD_GLTF_LOADER_H

#include <stddef.h>
#include <stdint.h>

#include "renderer/scene/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum rd_gltf_result {
    RD_GLTF_OK = 0,
    RD_GLTF_ERR_IO,          /* the file or an external buffer/image could not be read */
    RD_GLTF_ERR_PARSE,       /* not JSON, broken GLB container, empty file */
    RD_GLTF_ERR_INVALID,     /* violates glTF 2.0 (bad index, out-of-bounds accessor, NaN) */
    RD_GLTF_ERR_UNSUPPORTED, /* needs an extension listed in extensionsRequired we lack */
    RD_GLTF_ERR_TOO_LARGE,   /* exceeds max_triangles or an image/file size limit */
} rd_gltf_result;

/* Static name of a result ("ok", "io error", ...). */
const char *rd_gltf_strerror(rd_gltf_result r);

/* Bounded memory for every input (issue 30): the images of one file may decode to at most
 * RD_GLTF_DECODE_RATIO times the bytes it brings (the file and the external files it reads),
 * never less than RD_GLTF_DECODE_FLOOR (a small file may still carry a 4096 x 4096 flat-colour
 * texture, 64 MiB as RGBA, several times over) and never more than RD_GLTF_DECODE_MAX. Real
 * models stay far below the ratio: JPEG and PNG textures decode to 4-30 times their size
 * (DamagedHelmet: 3.7 MB of images, 80 MiB decoded). The file cannot ask for more memory by
 * compressing well: a 200 KiB PNG of 16384 x 4096 one-colour pixels (256 MiB decoded) is refused
 * unless the file around it is 4 MiB. Each image alone is also held to 16384 pixels a side and
 * 2^26 pixels. */
#define RD_GLTF_DECODE_FLOOR ((uint64_t)256 << 20)
#define RD_GLTF_DECODE_RATIO 64u
#define RD_GLTF_DECODE_MAX ((uint64_t)2 << 30)
/* The decoded bytes a file of bytes_in bytes (the file and the external files read) may take. */
uint64_t rd_gltf_decode_limit(uint64_t bytes_in);

typedef struct rd_gltf_options {
    uint64_t max_triangles; /* over all meshes the scene uses; 0 = 50 million */
} rd_gltf_options;

/* Loads a .gltf or .glb file; external URIs resolve below the file's folder.
 * `out` need not be initialised (its previous content is not freed). On success it holds
 * the scene (rd_scene_update done, warnings in out->warnings); on failure it is left
 * destroyed (zeroed) and err (if errlen > 0) holds one sentence saying what is wrong.
 * opt may be NULL. */
rd_gltf_result rd_gltf_load_file(const char *path, const rd_gltf_options *opt, rd_scene *out,
                                 char *err, size_t errlen);

/* Same from memory: GLB when the data starts with "glTF", else JSON text. With base_dir NULL
 * every external (non data:) URI is rejected. */
rd_gltf_result rd_gltf_load_memory(const void *data, size_t size, const char *base_dir,
                                   const rd_gltf_options *opt, rd_scene *out, char *err,
                                   size_t errlen);

#ifdef __cplusplus
}
#endif

#endif
