/* libFuzzer harness: arbitrary bytes as an uploaded environment image (rd_env_image_parse: the
 * Radiance .hdr and OpenEXR .exr readers, chosen by the first bytes). Seed the corpus with a few
 * small .hdr and .exr files. The readers reduce as they decode (to RD_ENV_IMAGE_MAX_WIDTH, as
 * the daemon does), so a decode holds at most a few hundred MiB whatever the file declares: the
 * default -malloc_limit_mb (the -rss_limit_mb, 2048) reports anything more. Build with
 * -DPROBECAST_FUZZ=ON using clang; run: build/tests/fuzz/fuzz_env_image CORPUS_DIR */
#include <stddef.h>
#include <stdint.h>

#include "renderer/env/environment.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_env_image img;
    char err[256];
    if (rd_env_image_parse(data, size, NULL, &img, err, sizeof err)) rd_env_image_free(&img);
    return 0;
}
