/* cli.h: the offline sub-commands of the probecast command line (render, eval); main.c
 * dispatches to them and to the daemon (server/serve.h). */
#ifndef SRV_CLI_H
#define SRV_CLI_H

#include "server/base/args.h"

/* Each returns the process exit status. */
int cli_render(int argc, char **argv);
int cli_eval(int argc, char **argv);

#endif
