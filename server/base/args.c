/* args.c: the command line's value parsers and SCENE argument (args.h). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/base/args.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/builtin/procedural.h"

const char *srv_arg_value(const char *cmd, int argc, char **argv, int *i)
{
    if (*i + 1 >= argc) {
        fprintf(stderr, "%s: %s needs a value\n", cmd, argv[*i]);
        return NULL;
    }
    return argv[++*i];
}

bool srv_arg_on_off(const char *opt, const char *s, bool *on)
{
    if (s && (strcmp(s, "on") == 0 || strcmp(s, "off") == 0)) {
        *on = strcmp(s, "on") == 0;
        return true;
    }
    fprintf(stderr, "probecast: %s expects on or off, got '%s'\n", opt, s ? s : "");
    return false;
}

bool srv_arg_uint(const char *opt, const char *s, unsigned min, unsigned max, unsigned *out)
{
    char *end = NULL;
    errno = 0;
    unsigned long v = s ? strtoul(s, &end, 10) : 0;
    if (!s || !*s || *end || errno || s[0] == '-' || v < min || v > max) {
        fprintf(stderr, "probecast: %s expects an integer in %u..%u, got '%s'\n", opt, min, max,
                s ? s : "");
        return false;
    }
    *out = (unsigned)v;
    return true;
}

bool srv_arg_float(const char *opt, const char *s, float *out)
{
    return srv_arg_floats(opt, s, out, 1);
}

bool srv_arg_floats(const char *opt, const char *s, float *out, int n)
{
    const char *p = s ? s : "";
    for (int i = 0; i < n; i++) {
        char *end = NULL;
        errno = 0;
        float v = strtof(p, &end);
        if (end == p || errno || !isfinite(v) || (i < n - 1 ? *end != ',' : *end != '\0')) {
            fprintf(stderr, "probecast: %s expects %d comma-separated number%s, got '%s'\n", opt, n,
                    n > 1 ? "s" : "", s ? s : "");
            return false;
        }
        out[i] = v;
        p = end + 1;
    }
    return true;
}

bool srv_arg_scene(const char *spec, rd_scene *scene)
{
    char err[512] = "";
    if (strncmp(spec, "builtin:", 8) == 0) {
        if (!rd_procedural_build(spec + 8, scene, err, sizeof err)) {
            fprintf(stderr, "probecast: %s\n", err);
            return false;
        }
        return true;
    }
    rd_gltf_result r = rd_gltf_load_file(spec, NULL, scene, err, sizeof err);
    if (r != RD_GLTF_OK) {
        fprintf(stderr, "probecast: cannot load '%s': %s\n", spec, err);
        return false;
    }
    for (uint32_t i = 0; i < scene->warning_count; i++)
        fprintf(stderr, "probecast: warning: %s\n", scene->warnings[i]);
    return true;
}
