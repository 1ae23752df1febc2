/* probecast: entry point. Dispatches to the sub-commands. */
#include <stdio.h>
#include <string.h>

#include "server/cli/cli.h"
#include "server/serve.h"

static void usage(FILE *f)
{
    fprintf(f, "usage: probecast COMMAND [OPTIONS]\n"
               "\n"
               "Commands:\n"
               "  render SCENE   render a glTF scene (or builtin:NAME) to an image\n"
               "  serve          run the daemon: HTTP API, WebSocket frame stream, browser viewer\n"
               "  eval           speed against error of GI settings on the hard-case suite\n"
               "\n"
               "Options:\n"
               "  --help         this text (also: probecast COMMAND --help)\n"
               "  --version      print the version\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 || strcmp(cmd, "help") == 0) {
        usage(stdout);
        return 0;
    }
    if (strcmp(cmd, "--version") == 0 || strcmp(cmd, "version") == 0) {
        printf("probecast %s\n", PROBECAST_VERSION);
        return 0;
    }
    if (strcmp(cmd, "render") == 0) return cli_render(argc - 1, argv + 1);
    if (strcmp(cmd, "serve") == 0) return srv_serve(argc - 1, argv + 1);
    if (strcmp(cmd, "eval") == 0) return cli_eval(argc - 1, argv + 1);
    fprintf(stderr, "probecast: unknown command '%s' (try probecast --help)\n", cmd);
    return 2;
}
