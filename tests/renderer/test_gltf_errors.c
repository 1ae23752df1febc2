/* test_gltf_errors.c: the glTF loader on broken files: a battery of invalid, unsupported and
 * oversized inputs that must each fail with its result code and a message naming the problem,
 * leaving the scene empty; then random mutations of a valid file, which must never crash. */
#include <math.h>
#include <png.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gltf_builder.h"
#include "renderer/gltf/gltf_loader.h"
#include "test_util.h"

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
    CHECKF(load_text(j, &s) == RD_GLTF_OK, "%s", gltf_err);
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
    CHECK(rd_gltf_load_memory(j, strlen(j), NULL, &opt, &s, gltf_err, sizeof gltf_err) ==
          RD_GLTF_ERR_TOO_LARGE);
    CHECKF(strstr(gltf_err, "triangles") != NULL, "%s", gltf_err);
    CHECK(scene_is_empty(&s));
    opt.max_triangles = 2;
    CHECK(rd_gltf_load_memory(j, strlen(j), NULL, &opt, &s, gltf_err, sizeof gltf_err) ==
          RD_GLTF_OK);
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
    CHECKF(rd_gltf_load_memory(glb, size, NULL, &opt, &s, gltf_err, sizeof gltf_err) == RD_GLTF_OK,
           "%s", gltf_err);
    rd_scene_destroy(&s);
    CHECKF(rd_gltf_load_memory(text, strlen(text), NULL, &opt, &s, gltf_err, sizeof gltf_err) ==
               RD_GLTF_OK,
           "%s", gltf_err);
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
        rd_gltf_result r = rd_gltf_load_memory(m, n, NULL, &opt, &s, gltf_err, sizeof gltf_err);
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

/* Bounded memory (issue 30): image sizes are read from their headers before anything is decoded;
 * one image may not pass 16384 pixels a side or 2^26 pixels, and all images of a file together
 * may decode to rd_gltf_decode_limit of the bytes it brings. */
static void test_image_limits(void)
{
    CHECK(rd_gltf_decode_limit(0) == RD_GLTF_DECODE_FLOOR);
    CHECK(rd_gltf_decode_limit(4u << 20) == RD_GLTF_DECODE_FLOOR);
    CHECK(rd_gltf_decode_limit(8u << 20) == (uint64_t)RD_GLTF_DECODE_RATIO * (8u << 20));
    CHECK(rd_gltf_decode_limit((uint64_t)1 << 40) == RD_GLTF_DECODE_MAX);
    rd_scene s;
    size_t size;
    struct {
        int w, h;
        const char *needle;
    } alone[] = {{16385, 1, "its size 16385x1 exceeds the limit"},
                 {8193, 8192, "its size 8193x8192 exceeds the limit"}};
    for (size_t i = 0; i < sizeof alone / sizeof alone[0]; i++) {
        bin png;
        make_flat_png(&png, alone[i].w, alone[i].h);
        uint8_t *glb = make_glb_images(&png, 1, 0, &size);
        rd_gltf_result r = rd_gltf_load_memory(glb, size, NULL, NULL, &s, gltf_err, sizeof gltf_err);
        CHECKF(r == RD_GLTF_ERR_TOO_LARGE && strstr(gltf_err, alone[i].needle), "%s: %s",
               rd_gltf_strerror(r), gltf_err);
        CHECK(scene_is_empty(&s));
        free(glb);
        free(png.p);
    }
    /* a 16384 x 4096 image (256 MiB as RGBA, the floor) from a file of a few hundred KiB, then a
     * 2 x 2 one: the first decodes, the second is refused from its header; 4 MiB more of file
     * make room for it */
    bin png[2];
    make_flat_png(&png[0], 16384, 4096);
    make_flat_png(&png[1], 2, 2);
    uint8_t *glb = make_glb_images(png, 2, 0, &size);
    rd_gltf_result r = rd_gltf_load_memory(glb, size, NULL, NULL, &s, gltf_err, sizeof gltf_err);
    CHECKF(r == RD_GLTF_ERR_TOO_LARGE && strstr(gltf_err, "image 1") &&
               strstr(gltf_err, "past 256 MiB"),
           "%zu-byte file: %s: %s", size, rd_gltf_strerror(r), gltf_err);
    CHECK(scene_is_empty(&s));
    printf("a 16384x4096 image and a 2x2 one in %zu KiB: %s\n", size >> 10, gltf_err);
    free(glb);
    glb = make_glb_images(png, 2, (size_t)4 << 20, &size);
    r = rd_gltf_load_memory(glb, size, NULL, NULL, &s, gltf_err, sizeof gltf_err);
    CHECKF(r == RD_GLTF_OK, "%zu-byte file: %s: %s", size, rd_gltf_strerror(r), gltf_err);
    if (r == RD_GLTF_OK) rd_scene_destroy(&s);
    free(glb);
    free(png[0].p);
    free(png[1].p);
}

int main(void)
{
    test_errors();
    test_image_limits();
    test_mutations();
    return test_finish();
}
