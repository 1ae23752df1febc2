/* args.h: the command line's value parsers and its SCENE argument, shared by every sub-command
 * (serve, render, eval). Each prints one message to stderr on bad input and returns false. */
#ifndef SRV_ARGS_H
#define SRV_ARGS_H

#include <stdbool.h>

#include "renderer/scene/scene.h"

/* The value after option argv[*i] of sub-command cmd ("probecast render"): advances *i past it;
 * with none left, prints "cmd: OPT needs a value" and returns NULL. Every sub-command's loop
 * over argv takes its option values through this. */
const char *srv_arg_value(const char *cmd, int argc, char **argv, int *i);
bool srv_arg_uint(const char *opt, const char *s, unsigned min, unsigned max, unsigned *out);
bool srv_arg_float(const char *opt, const char *s, float *out);
bool srv_arg_floats(const char *opt, const char *s, float *out, int n);
/* "on" or "off" (a switch such as --reflections): *on set; else prints one message. */
bool srv_arg_on_off(const char *opt, const char *s, bool *on);

/* Loads SCENE: "builtin:NAME[:ARG]" or a .gltf/.glb path. Warnings go to stderr.
 * On failure prints one message and returns false. */
bool srv_arg_scene(const char *spec, rd_scene *scene);

#endif
