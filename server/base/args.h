/* args.h: the command line's value parsers and its SCENE argument, shared by every sub-command
 * (serve, render, eval). Each prints one message to stderr on bad input and returns false. */
#ifndef SRV_ARGS_H
#define SRV_ARGS_H

#include <stdbool.h>

#include "renderer/scene/scene.h"

bool srv_arg_uint(const char *opt, const char *s, unsigned min, unsigned max, unsigned *out);
bool srv_arg_float(const char *opt, const char *s, float *out);
bool srv_arg_floats(const char *opt, const char *s, float *out, int n);

/* Loads SCENE: "builtin:NAME[:ARG]" or a .gltf/.glb path. Warnings go to stderr.
 * On failure prints one message and returns false. */
bool srv_arg_scene(const char *spec, rd_scene *scene);

#endif
