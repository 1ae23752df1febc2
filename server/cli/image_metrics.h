/* image_metrics.h: error of a linear HDR test image against a reference of the same size. */
#ifndef RD_IMAGE_METRICS_H
#define RD_IMAGE_METRICS_H

#include <stddef.h>

typedef struct rd_image_error {
    double rmse;          /* sqrt(mean((t - r)^2)) over all channels */
    double rel_mse;       /* mean((t - r)^2 / (r^2 + 0.01)) */
    double smape;         /* mean(2|t - r| / (|t| + |r|)), terms with t = r = 0 count 0 */
    double mean_lum_bias; /* (mean luminance of t - of r) / of r (0 when r is black) */
    double p99_abs;       /* 99th percentile of |t - r| over all channels */
    size_t non_finite;    /* NaN or Inf values in the test image (excluded from the above) */
    size_t values;        /* channels compared */
} rd_image_error;

/* Compares test against ref, both rgb floats (3 per pixel), pixels of each. Channels where
 * the reference is not finite are skipped too. */
void rd_image_compare(const float *test, const float *ref, size_t pixels, rd_image_error *out);

#endif
