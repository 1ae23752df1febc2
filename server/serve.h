/* serve.h: `probecast serve`, the daemon's entry (serve.c): parses its flags, assembles the
 * scene service, render loop, encoders, HTTP API and frame stream, and runs until a signal.
 * Returns the process exit status. */
#ifndef SRV_SERVE_H
#define SRV_SERVE_H

int srv_serve(int argc, char **argv);

#endif
