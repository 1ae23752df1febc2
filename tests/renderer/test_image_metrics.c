/* Error metrics against hand-computed values. */
#include <math.h>

#include "server/cli/image_metrics.h"
#include "test_util.h"

int main(void)
{
    /* two pixels: test (1,1,1),(0,0,0); reference (1,1,1),(1,1,1) */
    const float t[6] = {1, 1, 1, 0, 0, 0}, r[6] = {1, 1, 1, 1, 1, 1};
    rd_image_error e;
    rd_image_compare(t, r, 2, &e);
    CHECK(e.values == 6 && e.non_finite == 0);
    CHECK(fabs(e.rmse - sqrt(0.5)) < 1e-9);
    CHECK(fabs(e.rel_mse - 0.5 / 1.01) < 1e-9);
    CHECK(fabs(e.smape - 1.0) < 1e-9);        /* half the terms are 2, half 0 */
    CHECK(fabs(e.mean_lum_bias + 0.5) < 1e-9); /* half the light is missing */
    CHECK(e.p99_abs == 1.0);

    /* identical images: every error is exactly zero */
    rd_image_compare(r, r, 2, &e);
    CHECK(e.rmse == 0 && e.rel_mse == 0 && e.smape == 0 && e.mean_lum_bias == 0 && e.p99_abs == 0);

    /* non-finite test values are counted and excluded */
    const float bad[6] = {NAN, 1, INFINITY, 1, 1, 1};
    rd_image_compare(bad, r, 2, &e);
    CHECK(e.non_finite == 2 && e.values == 4 && e.rmse == 0);

    /* black reference: relMSE uses the 0.01 guard, SMAPE counts 0/0 as 0 */
    const float z[3] = {0, 0, 0}, one[3] = {0.1f, 0, 0};
    rd_image_compare(one, z, 1, &e);
    CHECK(fabs(e.rel_mse - (0.01 / 0.01) / 3) < 1e-6);
    CHECK(fabs(e.smape - 2.0 / 3) < 1e-9);
    CHECK(e.mean_lum_bias == 0);

    /* p99 of 100 values 0..99 (abs errors) is 98 (the 99th smallest) */
    float a[300], b[300];
    for (int i = 0; i < 300; i++) a[i] = (float)(i / 3), b[i] = 0;
    rd_image_compare(a, b, 100, &e);
    CHECK(e.p99_abs == 98.0);
    return test_finish();
}
