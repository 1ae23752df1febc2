/* libFuzzer harness: arbitrary bytes as an uploaded environment image (rd_env_image_parse: the
 * Radiance .hdr and OpenEXR .exr readers, chosen by the first bytes). Seed the corpus with a few
 * small .hdr and .exr files. A file may declare up to RD_ENV_MAX_BYTES (2 GiB) of texels, which
 * the reader allocates before decoding: run with -malloc_limit_mb=2100 or more so that such an
 * allocation is not reported. Build with -DPROBECAST_FUZZ=ON using clang; run:
 * build/tests/fuzz/fuzz_env_image CORPUS_DIR */
#include <stddef.h>
#include <stdint.h>

#include "renderer/environment.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_env_image img;
    char err[256];
    if (rd_env_image_parse(data, size, &img, err, sizeof err)) rd_env_image_free(&img);
    return 0;
}
