/* probecast render end to end on lavapipe (the executable, as a user runs it) on a glTF model
 * whose only light is a small glowing detail: a 1 m textured card with a 1 cm emitter in front
 * of it. The renderer's rule gives it default lighting, so the image is lit like the same card
 * without the emitter under the key light, and `render` says why in one line; with
 * --default-lighting off it is black but for the detail. (The daemon's rule counted any
 * emission as light and rendered such models black.) */
#include <png.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/gltf_builder.h"
#include "serve_util.h"
#include "test_util.h"

#define W 48
#define H 32

/* The card (the standard unit quad, textured light grey, facing +z) and the 1 cm emitter of
 * `nits` (0: not emitting) 1 mm in front of its middle, as a self-contained .gltf. About 20
 * pixels show a metre: the emitter covers at most one pixel. */
static char *card_gltf(float nits)
{
    bin b;
    std_bin(&b, NULL);
    static const uint8_t grey[12] = {200, 200, 200, 180, 180, 180, 180, 180, 180, 200, 200, 200};
    bin png;
    make_png(&png, 2, 2, PNG_COLOR_TYPE_RGB, 8, grey);
    char *uri = png_data_uri(&png);
    char *rest = test_xprintf(
        "'images':[{'uri':'%s'}],'textures':[{'source':0}],"
        "'materials':[{'pbrMetallicRoughness':{'baseColorTexture':{'index':0},"
        "'metallicFactor':0}},"
        "{'pbrMetallicRoughness':{'baseColorFactor':[0.8,0.8,0.8,1],'metallicFactor':0},"
        "'emissiveFactor':[%d,%d,%d],'extensions':{'KHR_materials_emissive_strength':"
        "{'emissiveStrength':%g}}}],"
        "'extensionsUsed':['KHR_materials_emissive_strength'],"
        "'meshes':[{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2},"
        "'indices':3,'material':0}]},"
        "{'primitives':[{'attributes':{'POSITION':0,'NORMAL':1,'TEXCOORD_0':2},'indices':3,"
        "'material':1}]}],"
        "'nodes':[{'mesh':0,'translation':[-0.5,0,0]},"
        "{'mesh':1,'translation':[-0.005,0.495,0.001],'scale':[0.01,0.01,1]}],"
        "'scenes':[{'nodes':[0,1]}],'scene':0",
        uri, nits > 0, nits > 0, nits > 0, nits > 0 ? (double)nits : 1.0);
    char *json = gltf_json(&b, 0, NULL, NULL, rest);
    free(rest);
    free(uri);
    free(png.p);
    free(b.p);
    return json;
}

static bool write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f) return false;
    bool ok = fputs(text, f) >= 0;
    return fclose(f) == 0 && ok;
}

/* Runs probecast render on model with the extra options; returns the image's mean luminance
 * (-1 on failure) and its stdout and stderr in out. */
static double render(const char *model, const char *options, char *out, size_t outlen)
{
    char all[512];
    snprintf(all, sizeof all, "--probes 2,2,2 --rays 16 --frames 4 --seed 1 %s", options);
    float *lum = pc_render_luminance(model, all, W, H, out, outlen);
    if (!lum) return -1;
    double sum = 0;
    for (size_t i = 0; i < (size_t)W * H; i++)
        sum += lum[i];
    free(lum);
    return sum / (W * H);
}

int main(void)
{
    char glowing[256], plain[256];
    snprintf(glowing, sizeof glowing, "%s", test_tmp_path("card-glowing.gltf"));
    snprintf(plain, sizeof plain, "%s", test_tmp_path("card-plain.gltf"));
    char *a = card_gltf(2), *b = card_gltf(0);
    CHECK(write_text(glowing, a) && write_text(plain, b));
    free(a);
    free(b);

    static char out[16384];
    const char *line = "probecast: default lighting added (no lights, no environment, emitters "
                       "too weak: ";
    /* the card without emission, lit by default: the reference */
    double key = render(plain, "", out, sizeof out);
    CHECKF(strstr(out, line) != NULL, "the plain card: %s", out);
    /* with the glowing detail: lit the same, and said so once */
    double lit = render(glowing, "", out, sizeof out);
    const char *said = strstr(out, line);
    CHECKF(said != NULL && strstr(said + strlen(line), "default lighting added") == NULL,
           "one line says default lighting was added: %s", out);
    /* turned off: black but for the emitter */
    double off = render(glowing, "--default-lighting off", out, sizeof out);
    CHECKF(strstr(out, "default lighting") == NULL, "nothing said when off: %s", out);
    printf("mean luminance: plain card %.4f, with the emitter %.4f, default lighting off %.5f\n",
           key, lit, off);
    CHECKF(key > 0.05, "the key-lit card is lit: %g", key);
    CHECKF(lit > 0.95 * key && lit < 1.05 * key, "the glowing card %g, the plain card %g", lit,
           key);
    CHECKF(off >= 0 && off < 0.02 * key, "without default lighting %g", off);
    return test_finish();
}
