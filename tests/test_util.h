/* test_util.h: minimal assertion helpers. A failed CHECK prints file:line and the condition
 * and marks the test failed; tests end with `return test_finish();`. */
#ifndef PC_TEST_UTIL_H
#define PC_TEST_UTIL_H

#include <stdio.h>

extern int test_failures;
extern int test_checks;

#define CHECK(cond)                                                                             \
    do {                                                                                        \
        test_checks++;                                                                          \
        if (!(cond)) {                                                                          \
            test_failures++;                                                                    \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);            \
        }                                                                                       \
    } while (0)

#define CHECKF(cond, ...)                                                                       \
    do {                                                                                        \
        test_checks++;                                                                          \
        if (!(cond)) {                                                                          \
            test_failures++;                                                                    \
            fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond);            \
            fprintf(stderr, __VA_ARGS__);                                                       \
            fputc('\n', stderr);                                                                \
        }                                                                                       \
    } while (0)

/* Relative closeness: |a - b| <= tol * max(|b|, tiny). */
int test_close_rel(double a, double b, double tol);
/* Prints a summary and returns the process exit code (0 when every check passed and at
 * least one ran). */
int test_finish(void);
/* Writes a scratch path under the build tree's test output folder. */
const char *test_tmp_path(const char *name);

#endif
