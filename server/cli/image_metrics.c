#include "server/cli/image_metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static double luminance(const float *p)
{
    return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}

void rd_image_compare(const float *test, const float *ref, size_t pixels, rd_image_error *out)
{
    memset(out, 0, sizeof *out);
    size_t n = pixels * 3;
    float *abs_err = malloc((n ? n : 1) * sizeof(float));
    if (!abs_err) abort();
    double se = 0, rel = 0, smape = 0, lum_t = 0, lum_r = 0;
    size_t count = 0, lum_pixels = 0;
    for (size_t i = 0; i < n; i++) {
        double t = test[i], r = ref[i];
        if (!isfinite(t)) {
            out->non_finite++;
            continue;
        }
        if (!isfinite(r)) continue;
        double d = t - r;
        se += d * d;
        rel += d * d / (r * r + 0.01);
        double denom = fabs(t) + fabs(r);
        smape += denom > 0 ? 2 * fabs(d) / denom : 0;
        abs_err[count++] = (float)fabs(d);
    }
    for (size_t p = 0; p < pixels; p++) {
        double lt = luminance(&test[p * 3]), lr = luminance(&ref[p * 3]);
        if (!isfinite(lt) || !isfinite(lr)) continue;
        lum_t += lt;
        lum_r += lr;
        lum_pixels++;
    }
    out->values = count;
    if (count) {
        out->rmse = sqrt(se / count);
        out->rel_mse = rel / count;
        out->smape = smape / count;
        qsort(abs_err, count, sizeof(float), cmp_float);
        size_t k = (size_t)ceil(0.99 * count) - 1;
        out->p99_abs = abs_err[k < count ? k : count - 1];
    }
    if (lum_pixels && lum_r > 0) out->mean_lum_bias = (lum_t - lum_r) / lum_r;
    free(abs_err);
}
