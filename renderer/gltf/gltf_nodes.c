/* gltf_nodes.c: the glTF node hierarchy and node transforms (see gltf_import.h). */
#include "renderer/gltf/gltf_import.h"

#include <stdlib.h>
#include <string.h>

#include "renderer/scene/xform.h"

/* Every child in range, each with one parent; then no parent chain returns to itself. */
static rd_gltf_result link_parents(size_t count, const rd_gltf_node_list *children, int *parent,
                                   char *err, size_t errlen)
{
    for (size_t i = 0; i < count; i++)
        parent[i] = -1;
    for (size_t i = 0; i < count; i++) {
        for (size_t k = 0; k < children[i].count; k++) {
            int c = children[i].nodes[k];
            if (c < 0 || (size_t)c >= count)
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "node %zu lists child %d, but there are only %zu nodes", i, c,
                                    count);
            if ((size_t)c == i)
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "node %zu is its own child (a cycle)", i);
            if (parent[c] >= 0)
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "node %d has two parents (nodes %d and %zu)", c, parent[c], i);
            parent[c] = (int)i;
        }
    }
    /* with single parents, a cycle is a parent chain that returns to itself */
    uint8_t *state = rd_gltf_alloc(count, 1);
    size_t *chain = rd_gltf_alloc(count, sizeof *chain);
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t i = 0; i < count && r == RD_GLTF_OK; i++) {
        size_t len = 0;
        int j = (int)i;
        while (j >= 0 && state[j] == 0) {
            state[j] = 1;
            chain[len++] = (size_t)j;
            j = parent[j];
        }
        if (j >= 0 && state[j] == 1)
            r = rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                             "the node hierarchy contains a cycle through node %d", j);
        for (size_t k = 0; k < len; k++)
            state[chain[k]] = 2;
    }
    free(state);
    free(chain);
    return r;
}

rd_gltf_result rd_gltf_hierarchy(size_t count, const rd_gltf_node_list *children,
                                 size_t scene_count, const rd_gltf_node_list *scenes,
                                 int default_scene, int *parent, size_t *order, size_t *order_count,
                                 char *err, size_t errlen)
{
    *order_count = 0;
    if (count > (size_t)INT32_MAX)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_TOO_LARGE, "the file has too many nodes");
    rd_gltf_result r = link_parents(count, children, parent, err, errlen);
    if (r != RD_GLTF_OK) return r;

    const int *roots = NULL;
    size_t root_count = 0;
    int *all_roots = NULL; /* without scenes: every parentless node */
    if (scene_count) {
        size_t scene = 0;
        if (default_scene >= 0 && (size_t)default_scene < scene_count)
            scene = (size_t)default_scene;
        else if (default_scene != -1)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "the default scene %d does not exist", default_scene);
        roots = scenes[scene].nodes;
        root_count = scenes[scene].count;
        for (size_t k = 0; k < root_count; k++) {
            int rt = roots[k];
            if (rt < 0 || (size_t)rt >= count)
                return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                    "scene %zu lists node %d, but there are only %zu nodes", scene,
                                    rt, count);
            if (parent[rt] >= 0)
                return rd_gltf_fail(
                    err, errlen, RD_GLTF_ERR_INVALID,
                    "scene %zu lists node %d as a root, but it is a child of node %d", scene, rt,
                    parent[rt]);
        }
    } else {
        all_roots = rd_gltf_alloc(count, sizeof *all_roots);
        for (size_t i = 0; i < count; i++)
            if (parent[i] < 0) all_roots[root_count++] = (int)i;
        roots = all_roots;
    }
    /* depth first, children in their listed order: each node is pushed once as a child, and
     * once per listing as a root */
    uint8_t *seen = rd_gltf_alloc(count, 1);
    size_t *stack = rd_gltf_alloc(count + root_count, sizeof *stack), top = 0;
    for (size_t k = root_count; k-- > 0;)
        stack[top++] = (size_t)roots[k];
    while (top) {
        size_t n = stack[--top];
        if (seen[n]) continue;
        seen[n] = 1;
        order[(*order_count)++] = n;
        for (size_t k = children[n].count; k-- > 0;)
            stack[top++] = (size_t)children[n].nodes[k];
    }
    free(seen);
    free(stack);
    free(all_roots);
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_node_transform(size_t index, const rd_gltf_transform *g, rd_node *n,
                                      char *err, size_t errlen)
{
    bool ok = true;
    if (g->matrix_count) {
        if (g->matrix_count != 16)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "node %zu has a matrix with %zu values instead of 16", index,
                                g->matrix_count);
        n->has_matrix = true;
        for (int k = 0; k < 16; k++)
            ok = ok && rd_gltf_to_float(g->matrix[k], &n->matrix[k]);
    } else {
        n->has_matrix = false;
    }
    float t[3] = {0, 0, 0}, r[4] = {0, 0, 0, 1}, sc[3] = {1, 1, 1};
    struct {
        const double *v;
        size_t count;
        float *dst;
        size_t n;
        const char *name;
    } parts[] = {{g->translation, g->translation_count, t, 3, "translation"},
                 {g->rotation, g->rotation_count, r, 4, "rotation"},
                 {g->scale, g->scale_count, sc, 3, "scale"}};
    for (size_t i = 0; i < 3; i++) {
        if (!parts[i].count) continue;
        if (parts[i].count != parts[i].n)
            return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                                "node %zu has a %s with %zu values instead of %zu", index,
                                parts[i].name, parts[i].count, parts[i].n);
        for (size_t k = 0; k < parts[i].n; k++)
            ok = ok && rd_gltf_to_float(parts[i].v[k], &parts[i].dst[k]);
    }
    if (!ok)
        return rd_gltf_fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "node %zu has a transform that is not finite", index);
    memcpy(n->translation, t, sizeof t);
    memcpy(n->rotation, r, sizeof r);
    memcpy(n->scale, sc, sizeof sc);
    if (!n->has_matrix) rd_mat4_identity(n->matrix);
    return RD_GLTF_OK;
}
