/* skin_builder.c: glTF test files with skins (see skin_builder.h). */
#include "skin_builder.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

/* A buffer of regions, one buffer view and one accessor each (accessor i reads view i). */

/* Appends size bytes read by an accessor described by acc (componentType, count, type ...). */
int gltf_file_add(gltf_file *f, const void *p, size_t size, const char *acc)
{
    CHECK(f->n + size <= sizeof f->data);
    memcpy(f->data + f->n, p, size);
    size_t vl = strlen(f->views), al = strlen(f->accessors);
    snprintf(f->views + vl, sizeof f->views - vl,
             "%s{'buffer':0,'byteOffset':%zu,'byteLength':%zu}", f->count ? "," : "", f->n, size);
    snprintf(f->accessors + al, sizeof f->accessors - al, "%s{'bufferView':%d,%s}",
             f->count ? "," : "", f->count, acc);
    f->n += size;
    while (f->n % 4)
        f->data[f->n++] = 0;
    return f->count++;
}

/* The glTF JSON text of f with the top-level members rest (single quotes). */
char *gltf_file_json(const gltf_file *f, const char *rest)
{
    char *b64 = test_base64(f->data, f->n);
    char *s = test_xprintf("{'asset':{'version':'2.0'},'buffers':[{'byteLength':%zu,'uri':"
                           "'data:application/octet-stream;base64,%s'}],'bufferViews':[%s],"
                           "'accessors':[%s],%s}",
                           f->n, b64, f->views, f->accessors, rest);
    char *j = test_jq(s);
    free(s);
    free(b64);
    return j;
}

const float kArmPos[18] = {0, -0.1f, 0, 0, 0.1f,  0, 1, -0.1f, 0,
                           1, 0.1f,  0, 2, -0.1f, 0, 2, 0.1f,  0};
const uint16_t kArmIdx[12] = {0, 2, 3, 0, 3, 1, 2, 4, 5, 2, 5, 3};

char *gltf_arm(int kind)
{
    gltf_file f;
    memset(&f, 0, sizeof f);
    float nrm[18], tan[24];
    for (int v = 0; v < 6; v++) {
        nrm[v * 3] = 0, nrm[v * 3 + 1] = 0, nrm[v * 3 + 2] = 1;
        tan[v * 4] = 1, tan[v * 4 + 1] = 0, tan[v * 4 + 2] = 0, tan[v * 4 + 3] = 1;
    }
    gltf_file_add(
        &f, kArmPos, sizeof kArmPos,
        "'componentType':5126,'count':6,'type':'VEC3','min':[0,-0.1,0],'max':[2,0.1,0]"); /* 0 */
    gltf_file_add(&f, nrm, sizeof nrm, "'componentType':5126,'count':6,'type':'VEC3'");   /* 1 */
    gltf_file_add(&f, tan, sizeof tan, "'componentType':5126,'count':6,'type':'VEC4'");   /* 2 */
    gltf_file_add(&f, kArmIdx, sizeof kArmIdx,
                  "'componentType':5123,'count':12,'type':'SCALAR'"); /* 3 */
    uint8_t j8[24] = {0};
    uint16_t j16[24] = {0};
    for (int v = 2; v < 4; v++)
        j8[v * 4 + 1] = kind == ARM_TWO_SETS ? 0 : 1, j16[v * 4 + 1] = 1;
    for (int v = 4; v < 6; v++)
        j8[v * 4] = kind == ARM_BAD_JOINT ? 5 : 1, j16[v * 4] = 1;
    if (kind == ARM_NORMALIZED)
        gltf_file_add(&f, j16, sizeof j16, "'componentType':5123,'count':6,'type':'VEC4'"); /* 4 */
    else
        gltf_file_add(&f, j8, sizeof j8, "'componentType':5121,'count':6,'type':'VEC4'");
    float w[24] = {0};
    uint8_t w8[24] = {0};
    float scale = kind == ARM_HALF_WEIGHTS ? 0.5f : 1.0f;
    for (int v = 0; v < 6; v++) {
        bool mid = v == 2 || v == 3;
        w[v * 4] = (mid ? 0.5f : 1.0f) * scale;
        w[v * 4 + 1] = mid && kind != ARM_TWO_SETS ? 0.5f * scale : 0.0f;
        w8[v * 4] = mid ? 128 : 255;
        w8[v * 4 + 1] = mid ? 127 : 0;
    }
    if (kind == ARM_NORMALIZED)
        gltf_file_add(&f, w8, sizeof w8,
                      "'componentType':5121,'normalized':true,'count':6,'type':'VEC4'"); /* 5 */
    else
        gltf_file_add(&f, w, sizeof w, "'componentType':5126,'count':6,'type':'VEC4'");
    const float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0,  0, 0, 1,
                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 0, 1};
    gltf_file_add(&f, ibm, sizeof ibm, "'componentType':5126,'count':2,'type':'MAT4'"); /* 6 */
    const float times[3] = {0, 1, 2};
    gltf_file_add(&f, times, sizeof times,
                  "'componentType':5126,'count':3,'type':'SCALAR','min':[0],'max':[2]"); /* 7 */
    const float rot[12] = {0,           0,           0, 1, 0,           0,
                           0.70710678f, 0.70710678f, 0, 0, 0.70710678f, 0.70710678f};
    gltf_file_add(&f, rot, sizeof rot, "'componentType':5126,'count':3,'type':'VEC4'"); /* 8 */
    /* ARM_TWO_SETS: the middle vertices' elbow half in JOINTS_1 / WEIGHTS_1 */
    uint8_t j1[24] = {0};
    float w1[24] = {0};
    for (int v = 2; v < 4; v++)
        j1[v * 4] = 1, w1[v * 4] = 0.5f;
    gltf_file_add(&f, j1, sizeof j1, "'componentType':5121,'count':6,'type':'VEC4'"); /* 9 */
    gltf_file_add(&f, w1, sizeof w1, "'componentType':5126,'count':6,'type':'VEC4'"); /* 10 */
    char *rest =
        test_xprintf("'meshes':[{'name':'arm','primitives':[{'attributes':{'POSITION':0,'NORMAL':1,"
                     "'TANGENT':2,'JOINTS_0':4,'WEIGHTS_0':5%s},'indices':3}]}],"
                     "'skins':[{'joints':[1,2],'inverseBindMatrices':6,'skeleton':1}],"
                     "'nodes':[{'name':'arm','mesh':0,'skin':0,'translation':[0,0,5]},"
                     "{'name':'shoulder','children':[2]},"
                     "{'name':'elbow','translation':[1,0,0]}],'scenes':[{'nodes':[0,1]}],"
                     "'animations':[{'samplers':[{'input':7,'output':8}],'channels':[{'sampler':0,"
                     "'target':{'node':2,'path':'rotation'}}]}]",
                     kind == ARM_TWO_SETS ? ",'JOINTS_1':9,'WEIGHTS_1':10" : "");
    char *j = gltf_file_json(&f, rest);
    free(rest);
    return j;
}

/* The arm with a camera 4 m in front of its middle (looking down -Z). */
char *gltf_arm_with_camera(void)
{
    char *text = gltf_arm(ARM_FLOAT);
    const char *elbow = "{\"name\":\"elbow\",\"translation\":[1,0,0]}]";
    const char *roots = "\"scenes\":[{\"nodes\":[0,1]}]";
    char *e = strstr(text, elbow), *r = strstr(text, roots);
    CHECK(e != NULL && r != NULL && e < r);
    if (!e || !r || r < e) abort();
    char *out = test_xprintf(
        "%.*s{\"name\":\"elbow\",\"translation\":[1,0,0]},{\"name\":\"cam\",\"camera\":0,"
        "\"translation\":[1,0.4,4]}],\"cameras\":[{\"type\":\"perspective\",\"perspective\":"
        "{\"yfov\":0.7,\"znear\":0.05}}]%.*s\"scenes\":[{\"nodes\":[0,1,3]}]%s",
        (int)(e - text), text, (int)(r - (e + strlen(elbow))), e + strlen(elbow),
        r + strlen(roots));
    free(text);
    return out;
}

char *gltf_morph_cube(void)
{
    gltf_file f;
    memset(&f, 0, sizeof f);
    float pos[24], d0[24], d1[24], n1[24];
    for (int v = 0; v < 8; v++) {
        pos[v * 3] = v & 1 ? 1 : -1, pos[v * 3 + 1] = v & 2 ? 1 : -1,
                pos[v * 3 + 2] = v & 4 ? 1 : -1;
        d0[v * 3] = 1, d0[v * 3 + 1] = 0, d0[v * 3 + 2] = 0;
        d1[v * 3] = 0, d1[v * 3 + 1] = 0, d1[v * 3 + 2] = v & 4 ? 2 : 0;
        n1[v * 3] = v & 4 ? 1 : 0, n1[v * 3 + 1] = 0, n1[v * 3 + 2] = 0;
    }
    static const uint16_t idx[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    gltf_file_add(
        &f, pos, sizeof pos,
        "'componentType':5126,'count':8,'type':'VEC3','min':[-1,-1,-1],'max':[1,1,1]");    /* 0 */
    gltf_file_add(&f, idx, sizeof idx, "'componentType':5123,'count':36,'type':'SCALAR'"); /* 1 */
    gltf_file_add(&f, d0, sizeof d0, "'componentType':5126,'count':8,'type':'VEC3'");      /* 2 */
    gltf_file_add(&f, d1, sizeof d1, "'componentType':5126,'count':8,'type':'VEC3'");      /* 3 */
    gltf_file_add(&f, n1, sizeof n1, "'componentType':5126,'count':8,'type':'VEC3'");      /* 4 */
    const float times[3] = {0, 1, 2};
    gltf_file_add(&f, times, sizeof times,
                  "'componentType':5126,'count':3,'type':'SCALAR','min':[0],'max':[2]"); /* 5 */
    const float w[6] = {0, 0, 1, 0.5f, 0, 1};
    gltf_file_add(&f, w, sizeof w, "'componentType':5126,'count':6,'type':'SCALAR'"); /* 6 */
    const float cubic[18] = {0, 0, 0, 0,    1, 0,  /* key 0: in, value, out */
                             0, 0, 1, 0.5f, 0, 0,  /* key 1 */
                             0, 0, 0, 1,    0, 0}; /* key 2 */
    gltf_file_add(&f, cubic, sizeof cubic,
                  "'componentType':5126,'count':18,'type':'SCALAR'"); /* 7 */
    float tan[32];
    for (int v = 0; v < 8; v++)
        tan[v * 4] = 1, tan[v * 4 + 1] = 0, tan[v * 4 + 2] = 0, tan[v * 4 + 3] = 1;
    gltf_file_add(&f, tan, sizeof tan, "'componentType':5126,'count':8,'type':'VEC4'"); /* 8 */
    /* target 1's TANGENT: (0, 1, 0) on the top four vertices, a sparse accessor over zeros */
    const uint8_t top[4] = {4, 5, 6, 7};
    const float up[12] = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
    gltf_file_add(&f, top, sizeof top, "'componentType':5121,'count':4,'type':'SCALAR'"); /* 9 */
    gltf_file_add(&f, up, sizeof up, "'componentType':5126,'count':4,'type':'VEC3'");     /* 10 */
    size_t al = strlen(f.accessors);
    snprintf(f.accessors + al, sizeof f.accessors - al,
             ",{'componentType':5126,'count':8,'type':'VEC3','sparse':{'count':4,'indices':"
             "{'bufferView':9,'componentType':5121},'values':{'bufferView':10}}}"); /* 11 */
    f.count++;
#define CUBE_PRIM                                                                                  \
    "{'primitives':[{'attributes':{'POSITION':0,'TANGENT':8},'indices':1,'targets':[{'POSITION':"  \
    "2},{'POSITION':3,'NORMAL':4,'TANGENT':11}]}]"
    return gltf_file_json(
        &f, "'meshes':[" CUBE_PRIM ",'weights':[0.25,0]}," CUBE_PRIM "}," CUBE_PRIM "}],"
            "'nodes':[{'name':'step','mesh':0},{'name':'linear','mesh':1},"
            "{'name':'spline','mesh':2},{'name':'fixed','mesh':0,'weights':[0,0.5]}],"
            "'scenes':[{'nodes':[0,1,2]}],"
            "'animations':[{'samplers':[{'input':5,'output':6,'interpolation':'STEP'},"
            "{'input':5,'output':6},{'input':5,'output':7,'interpolation':'CUBICSPLINE'}],"
            "'channels':[{'sampler':0,'target':{'node':0,'path':'weights'}},"
            "{'sampler':1,'target':{'node':1,'path':'weights'}},"
            "{'sampler':2,'target':{'node':2,'path':'weights'}}]}]");
}
