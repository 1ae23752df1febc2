/* scene.h: the CPU-side scene model (what a glTF file or a procedural generator produces).
 *
 * Triangles are stored expanded (three vertices per triangle, no index buffer): the BVH
 * reorders them anyway and it keeps every consumer simple. Matrices are column-major
 * float[16] as in glTF. The scene owns every array it points to; rd_scene_destroy frees them.
 */
#ifndef RD_SCENE_H
#define RD_SCENE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Per-vertex deformation of a mesh (glTF 2.0 skins and morph targets, sections 3.7.3.3 and
 * 3.7.2.2) in flat arrays a GPU pass can upload as they are. Vertex v is corner v of the
 * expanded triangles (v = 3 * triangle + corner), as in rd_mesh. rd_scene_update deforms the
 * mesh (renderer/scene/deform.h): rd_mesh's positions, normals and tangents then hold the posed
 * shape, morphed first, then skinned. Owned by its mesh. */
typedef struct rd_mesh_deform {
    uint32_t vertex_count; /* 3 * tri_count */
    float *rest_positions; /* 3 floats per vertex: the shape without targets or skin */
    float *rest_normals;   /* 3 floats per vertex */
    float *rest_tangents;  /* 4 floats per vertex, or NULL when the mesh has no tangents */
    /* Skin: `influences` (0, 4 or 8) joints and weights per vertex, joints[v * influences + k]
     * indexing the joints of the skin of the node that draws the mesh; the weights sum to one,
     * or are all zero (the vertex then stays where it is in the mesh node's space). max_joint:
     * the largest joint a weighted influence uses. */
    uint32_t influences;
    uint16_t *joints;
    float *weights;
    uint32_t max_joint;
    /* Morph targets: target t's delta for vertex v at [(t * vertex_count + v) * 3] (xyz, also
     * for tangents); each array NULL when no target has that attribute. */
    uint32_t target_count;
    float *target_positions, *target_normals, *target_tangents;
    float *default_weights; /* target_count: the mesh's weights (0 where not given) */
    /* The pose last applied (deform.c): joint matrices, then weights; revision grows each time
     * the deformed shape changes, so that consumers (the GPU scene) know which meshes to rebuild.
     */
    float *posed;
    size_t posed_count;
    uint64_t revision;
} rd_mesh_deform;

typedef struct rd_mesh {
    char *name;
    uint32_t tri_count;
    float *positions; /* 9 floats per triangle, object space */
    float *normals;   /* 9 floats per triangle (unit vectors) */
    float *uvs;       /* 6 floats per triangle (TEXCOORD_0; zeros when absent) */
    /* 12 floats per triangle (TANGENT: xyz unit tangent, w = +-1 handedness, per vertex), or
     * NULL: the renderer then derives tangents per triangle from the UVs. Owned; malloc'd. */
    float *tangents;
    uint32_t *material;     /* material index per triangle (always valid: see default material) */
    rd_mesh_deform *deform; /* NULL: the mesh is rigid */
} rd_mesh;

typedef struct rd_node {
    char *name;
    int32_t parent; /* -1 for roots */
    int32_t mesh;   /* -1 when the node has no mesh */
    float translation[3];
    float rotation[4]; /* quaternion x, y, z, w */
    float scale[3];
    float matrix[16]; /* used instead of TRS when has_matrix */
    bool has_matrix;
    float world[16]; /* filled by rd_scene_update */
    uint32_t skin;   /* skin index + 1 that deforms the node's mesh; 0: none */
    /* Morph target weights of the node's mesh (glTF node.weights, else the mesh's), animated by
     * RD_ANIM_WEIGHTS channels; weight_count 0: the mesh's defaults. Owned (copied by
     * rd_scene_add_node). */
    float *weights;
    uint32_t weight_count;
} rd_node;

/* A glTF skin: the nodes that are its joints and their inverse bind matrices. */
typedef struct rd_skin {
    char *name;
    uint32_t joint_count;
    uint32_t *joints;    /* rd node per joint */
    float *inverse_bind; /* 16 floats per joint, column-major (identity when the file has none) */
} rd_skin;

enum { RD_ALPHA_OPAQUE = 0, RD_ALPHA_MASK = 1, RD_ALPHA_BLEND = 2 };
enum { RD_WRAP_REPEAT = 0, RD_WRAP_CLAMP = 1, RD_WRAP_MIRROR = 2 };

/* glTF 2.0 metallic-roughness material; the BRDF is the glTF 2.0 specification's Appendix B
 * (shaders/brdf.glsl). Texture indices are -1 when absent (a zeroed struct is NOT a valid
 * material: set every texture index). Zero metallic and specular give a pure Lambertian,
 * which procedural scenes and the analytic tests use. */
typedef struct rd_material {
    char *name;
    float base_color[4]; /* linear factor, alpha in [3] */
    float emission[3];   /* emissiveFactor * KHR_materials_emissive_strength */
    float metallic;      /* metallicFactor, 0..1 */
    float roughness;     /* roughnessFactor (perceptual: GGX alpha = roughness^2), 0..1 */
    /* weight of the dielectric specular lobe (the F of Appendix B's dielectric mix is scaled by
     * it): 1 for glTF materials, 0 for a pure Lambertian dielectric. Metals ignore it. */
    float specular;
    float normal_scale;                 /* normalTexture.scale (default 1) */
    float occlusion_strength;           /* occlusionTexture.strength (default 1) */
    int32_t base_color_texture;         /* texture index or -1 */
    int32_t emissive_texture;           /* texture index or -1 */
    int32_t metallic_roughness_texture; /* B = metallic, G = roughness (linear), or -1 */
    int32_t normal_texture;             /* tangent-space normal map (linear), or -1 */
    int32_t occlusion_texture;          /* R = occlusion (linear), or -1 */
    uint32_t alpha_mode;                /* RD_ALPHA_* */
    float alpha_cutoff;                 /* default 0.5 */
    bool double_sided;
} rd_material;

typedef struct rd_texture {
    uint32_t width, height;
    /* width * height * 4 bytes as stored in the file: colour textures are sRGB-encoded, data
     * textures (metallic-roughness, normal, occlusion) linear; the sampler decides */
    uint8_t *rgba;
    uint32_t wrap_s, wrap_t; /* RD_WRAP_* */
    bool nearest;            /* magFilter NEAREST */
} rd_texture;

enum { RD_LIGHT_POINT = 0, RD_LIGHT_SPOT = 1, RD_LIGHT_DIRECTIONAL = 2 };

typedef struct rd_light {
    char *name;
    uint32_t type;                /* RD_LIGHT_* */
    float color[3];               /* linear */
    float intensity;              /* candela (point, spot) or lux (directional) */
    float range;                  /* 0 = unlimited */
    float inner_cone, outer_cone; /* radians (spot) */
    int32_t node;       /* node that places the light, or -1 (then position/direction are world) */
    float position[3];  /* world, filled by rd_scene_update when node >= 0 */
    float direction[3]; /* world unit vector the light shines toward (node's -Z) */
} rd_light;

typedef struct rd_camera {
    char *name;
    float yfov;   /* radians */
    float aspect; /* 0 = unknown (use the image's) */
    float znear;
    int32_t node;      /* node that places the camera, or -1 */
    float position[3]; /* world, filled by rd_scene_update when node >= 0 */
    float forward[3];  /* world unit vectors: node's -Z and +Y */
    float up[3];
} rd_camera;

/* A mesh placed by a node: one per node that has a mesh (filled by rd_scene_update). */
typedef struct rd_instance {
    uint32_t node;
    uint32_t mesh;
} rd_instance;

/* Node animation (glTF 2.0 animations targeting translation, rotation, scale or morph weights).
 * renderer/scene/animation_clip.h samples them into the nodes' TRS and weights. */
enum { RD_ANIM_TRANSLATION = 0, RD_ANIM_ROTATION = 1, RD_ANIM_SCALE = 2, RD_ANIM_WEIGHTS = 3 };
/* Most values one key holds (the morph targets a weights channel animates). */
#define RD_ANIM_MAX_COMPONENTS 256u
enum { RD_INTERP_LINEAR = 0, RD_INTERP_STEP = 1, RD_INTERP_CUBICSPLINE = 2 };

typedef struct rd_anim_sampler {
    uint32_t interpolation; /* RD_INTERP_* */
    /* per value: 3 (translation, scale), 4 (quaternion x, y, z, w) or, for weights, the node's
     * weight count (1 .. RD_ANIM_MAX_COMPONENTS) */
    uint32_t components;
    uint32_t key_count; /* >= 1 */
    float *times;       /* key_count finite seconds >= 0, non-decreasing */
    /* key_count * components floats; CUBICSPLINE: key_count * 3 * components, each key
     * stored as in-tangent, value, out-tangent (glTF 2.0 appendix C) */
    float *values;
} rd_anim_sampler;

typedef struct rd_anim_channel {
    uint32_t node;    /* rd node index (a TRS node) */
    uint32_t path;    /* RD_ANIM_* */
    uint32_t sampler; /* index into the animation's samplers */
} rd_anim_channel;

typedef struct rd_animation {
    char *name;
    float duration; /* loop length, >= the last key time of every sampler */
    rd_anim_sampler *samplers;
    uint32_t sampler_count;
    rd_anim_channel *channels;
    uint32_t channel_count;
} rd_animation;

typedef struct rd_scene {
    rd_mesh *meshes;
    uint32_t mesh_count;
    rd_node *nodes;
    uint32_t node_count;
    rd_material *materials; /* materials[0] is always the default (white, opaque, single sided) */
    uint32_t material_count;
    rd_texture *textures;
    uint32_t texture_count;
    rd_light *lights;
    uint32_t light_count;
    rd_camera *cameras;
    uint32_t camera_count;
    rd_instance *instances;
    uint32_t instance_count;
    rd_animation *animations;
    uint32_t animation_count;
    rd_skin *skins;
    uint32_t skin_count;
    char **warnings; /* human sentences about ignored features */
    uint32_t warning_count;
    float bounds_min[3], bounds_max[3]; /* world bounds of all instances (rd_scene_update) */
    uint64_t tri_total;                 /* triangles over all instances */
} rd_scene;

/* Initialises an empty scene holding only the default material. */
/* White, dielectric, fully rough, untextured, opaque, single sided: materials[0] of every
 * scene, and the start of materials built in code. */
rd_material rd_material_default(void);
void rd_scene_init(rd_scene *s);
/* Frees everything the scene owns and leaves it empty (idempotent). */
void rd_scene_destroy(rd_scene *s);
/* Frees a mesh's name, arrays and deformation (the mesh struct itself stays, its pointers
 * dangling: refill or drop it). */
void rd_mesh_free_arrays(rd_mesh *m);

/* Builders: each returns the new element's index; arrays grow as needed; strings are copied.
 * Out-of-memory aborts (the only fatal error). */
uint32_t rd_scene_add_material(rd_scene *s, const rd_material *m);
uint32_t rd_scene_add_texture(rd_scene *s, const rd_texture *t); /* takes ownership of t->rgba */
/* Adds a mesh with tri_count triangles whose arrays are allocated (zeroed) for the caller to fill.
 */
uint32_t rd_scene_add_mesh(rd_scene *s, const char *name, uint32_t tri_count);
uint32_t rd_scene_add_node(rd_scene *s, const rd_node *n); /* copies n->weights */
uint32_t rd_scene_add_skin(rd_scene *s, const rd_skin *k); /* copies joints, inverse_bind */
uint32_t rd_scene_add_light(rd_scene *s, const rd_light *l);
uint32_t rd_scene_add_camera(rd_scene *s, const rd_camera *c);
/* Deep-copies a (name, samplers with their times and values, channels); the copy's duration
 * is the largest of a->duration and its samplers' last key times. Asserts that key counts,
 * component counts and channel indices are consistent (node indices are checked when
 * sampling, as nodes may be added later). */
uint32_t rd_scene_add_animation(rd_scene *s, const rd_animation *a);
/* Removes light index (later lights move down by one); out-of-range indices are ignored. */
void rd_scene_remove_light(rd_scene *s, uint32_t index);
void rd_scene_warn(rd_scene *s, const char *fmt, ...);

/* Fills zero-length normals of a mesh with its triangles' flat (geometric) normals. */
void rd_mesh_fill_flat_normals(rd_mesh *m);

/* Recomputes world matrices (parents before children; a cycle is an error), the instance list,
 * light and camera world placement, the deformed meshes' shapes (deform.h: only those whose
 * joints or weights changed), bounds and tri_total. Returns false with a message in
 * err on a broken hierarchy. */
bool rd_scene_update(rd_scene *s, char *err, size_t errlen);

/* Node local matrix from TRS or matrix. */
void rd_node_local_matrix(const rd_node *n, float out[16]);

#ifdef __cplusplus
}
#endif

#endif
