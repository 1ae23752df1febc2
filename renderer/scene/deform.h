/* deform.h: skinned and morphing meshes posed on the CPU (glTF 2.0 sections 3.7.2.2 and 3.7.3.3):
 * a mesh's rest shape, moved by its morph targets' weights and then by its skin's joint matrices,
 * into the mesh's positions, normals and tangents. rd_scene_update runs it for every instance
 * whose joints or weights changed; this is also the reference a GPU deformation pass is tested
 * against. Data layout: rd_mesh_deform in scene.h. */
#ifndef RD_DEFORM_H
#define RD_DEFORM_H

#include <stdbool.h>
#include <stdint.h>

#include "renderer/scene/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Gives mesh m a deformation (m->deform, zeroed arrays): influences (0, 4 or 8) joints and
 * weights per vertex, target_count morph targets with position deltas, and normal and tangent
 * deltas when asked for (tangent deltas only where the mesh has tangents). The rest shape is
 * copied from the mesh's arrays by rd_mesh_deform_keep_rest once they are filled. Out of memory
 * aborts. */
rd_mesh_deform *rd_mesh_deform_create(rd_mesh *m, uint32_t influences, uint32_t target_count,
                                      bool target_normals, bool target_tangents);
/* Copies m's positions, normals and tangents into its deformation's rest shape. */
void rd_mesh_deform_keep_rest(rd_mesh *m);
void rd_mesh_deform_free(rd_mesh_deform *d); /* NULL is fine */

/* The joint matrices of skin k for the mesh that node `node` draws, 16 floats per joint into out:
 * inverse(node world) x joint world x inverse bind matrix, i.e. in the mesh node's space (the
 * glTF specification ignores the skinned mesh node's own transform; the instance transform puts
 * the node's world back). Call after the world matrices are up to date. */
void rd_skin_joint_matrices(const rd_scene *s, const rd_skin *k, uint32_t node, float *out);

/* Deforms m from its rest shape: morph targets first (weights, weight_count of them; 0: the
 * mesh's defaults), then the skin (joint_count matrices of 16 floats, or NULL: no skinning).
 * Normals follow the inverse transpose and are renormalised, tangents the matrix (w kept);
 * influences on a joint index past joint_count are left out, a vertex whose result is not finite
 * keeps its rest values. */
void rd_mesh_deform_apply(rd_mesh *m, const float *weights, uint32_t weight_count,
                          const float *joint_mats, uint32_t joint_count);

/* Poses every deformable mesh an instance draws for the nodes' current skins, world matrices and
 * weights (rd_scene_update calls it after the world matrices): a mesh whose inputs did not change
 * since its last pose is left alone; one that changed is deformed and its deform->revision
 * grows. A mesh drawn by several nodes takes the last one's pose (the glTF importer gives each
 * deforming node a mesh of its own). */
void rd_scene_deform(rd_scene *s);

#ifdef __cplusplus
}
#endif

#endif
