/* eval_report.h: the results of `probecast eval` as CSV, JSON, a terminal table and an SVG
 * speed-against-error chart (error on a log axis, Pareto front marked per scene). */
#ifndef SRV_EVAL_REPORT_H
#define SRV_EVAL_REPORT_H

#include <stdbool.h>
#include <stdio.h>

#include "server/cli/image_metrics.h"

typedef struct eval_row {
    char scene[48];
    char expect[256];
    char config[64]; /* e.g. "ddgi 8x8x8 r128 u32" */
    char mode[16];   /* direct, classic, default (what a user gets without flags), ddgi */
    unsigned probes[3], rays, updates; /* default: the updates it took to fall asleep */
    float hysteresis;
    double gpu_ms;        /* GPU time of one steady-state frame (one probe update + shading) */
    double sleep_ms;      /* default: GPU time of the updates until the field slept (else 0) */
    bool slept;           /* default: the field fell asleep within the cap */
    double ref_ms;        /* GPU time of the reference render */
    double noise_rel_mse; /* relMSE between two references of different seeds */
    rd_image_error err;
    bool pareto; /* on the speed/error Pareto front of its scene (by rel_mse) */
} eval_row;

/* Marks each row's pareto flag (per scene: no other row is both faster and more accurate). */
void eval_mark_pareto(eval_row *rows, unsigned n);
bool eval_write_csv(const char *path, const eval_row *rows, unsigned n);
bool eval_write_json(const char *path, const eval_row *rows, unsigned n, const char *device,
                     unsigned width, unsigned height, unsigned ref_spp);
bool eval_write_svg(const char *path, const eval_row *rows, unsigned n, const char *device);
void eval_print_table(FILE *f, const eval_row *rows, unsigned n);
/* Reads a CSV written by eval_write_csv (to redraw the chart); *rows is malloc'd.
 * Returns false on a malformed file. */
bool eval_read_csv(const char *path, eval_row **rows, unsigned *n);

#endif
