/* libFuzzer harness: arbitrary bytes as an uploaded .glb/.gltf (no file-system access).
 * Build with -DPROBECAST_FUZZ=ON using clang; run: build/tests/fuzz/fuzz_gltf CORPUS_DIR */
#include <stddef.h>
#include <stdint.h>

#include "renderer/gltf/gltf_loader.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_scene scene;
    char err[256];
    rd_gltf_options opt = {.max_triangles = 1000000};
    if (rd_gltf_load_memory(data, size, NULL, &opt, &scene, err, sizeof err) == RD_GLTF_OK)
        rd_scene_destroy(&scene);
    return 0;
}
