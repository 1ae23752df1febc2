/* cli.h: the probecast command line: one function per sub-command and shared option parsing. */
#ifndef SRV_CLI_H
#define SRV_CLI_H

#include <stdbool.h>

#include "renderer/scene.h"

/* Each returns the process exit status. */
int cli_render(int argc, char **argv);
int cli_serve(int argc, char **argv);
int cli_eval(int argc, char **argv);

/* Option value parsers: return false and print one message to stderr on bad input. */
bool cli_parse_uint(const char *opt, const char *s, unsigned min, unsigned max, unsigned *out);
bool cli_parse_float(const char *opt, const char *s, float *out);
bool cli_parse_floats(const char *opt, const char *s, float *out, int n);

/* Loads SCENE: "builtin:NAME[:ARG]" or a .gltf/.glb path. Warnings go to stderr.
 * On failure prints one message and returns false. */
bool cli_load_scene(const char *spec, rd_scene *scene);

#endif
