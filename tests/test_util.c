#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <sys/stat.h>

int test_failures = 0;
int test_checks = 0;

int test_close_rel(double a, double b, double tol)
{
    double scale = fabs(b) > 1e-30 ? fabs(b) : 1e-30;
    return isfinite(a) && fabs(a - b) <= tol * scale;
}

int test_finish(void)
{
    fprintf(stderr, "%d checks, %d failed\n", test_checks, test_failures);
    return (test_failures == 0 && test_checks > 0) ? 0 : 1;
}

const char *test_tmp_path(const char *name)
{
    static char path[4][1024];
    static int slot = 0;
    mkdir("test-output", 0755);
    slot = (slot + 1) % 4;
    snprintf(path[slot], sizeof path[slot], "test-output/%s", name);
    return path[slot];
}
