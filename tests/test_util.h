/* test_util.h: minimal assertion helpers. A failed CHECK prints file:line and the condition
 * and marks the test failed; tests end with `return test_finish();`. */
#ifndef PC_TEST_UTIL_H
#define PC_TEST_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

extern int test_failures;
extern int test_checks;

#define CHECK(cond)                                                                                \
    do {                                                                                           \
        test_checks++;                                                                             \
        if (!(cond)) {                                                                             \
            test_failures++;                                                                       \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);               \
        }                                                                                          \
    } while (0)

#define CHECKF(cond, ...)                                                                          \
    do {                                                                                           \
        test_checks++;                                                                             \
        if (!(cond)) {                                                                             \
            test_failures++;                                                                       \
            fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond);               \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fputc('\n', stderr);                                                                   \
        }                                                                                          \
    } while (0)

/* Relative closeness: |a - b| <= tol * max(|b|, tiny). */
int test_close_rel(double a, double b, double tol);
/* Prints a summary and returns the process exit code (0 when every check passed and at
 * least one ran). */
int test_finish(void);
/* A cube [-1,1]^3 with each face split into g x g cells of two triangles, counter-clockwise
 * seen from outside; writes 9 floats per triangle to pos (room for 6*g*g*2 triangles) and
 * returns the triangle count. */
uint32_t test_make_cube(float *pos, int g);
/* Writes a scratch path under the build tree's test output folder. */
const char *test_tmp_path(const char *name);

/* The whole file at path as a NUL-terminated string (NULL when it cannot be read; the caller
 * frees); its length in *len when len is not NULL. */
char *test_read_text(const char *path, size_t *len);

/* Writing test files. All results are malloc'd (the caller frees); out-of-memory aborts. */
char *test_xprintf(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Standard base64 of n bytes, '='-padded. */
char *test_base64(const uint8_t *p, size_t n);
/* Test JSON is written with single quotes; this turns them into double quotes. */
char *test_jq(const char *s);
/* The n bytes of text (and its '\0') copied into m with one to three random bytes at or after
 * `from` replaced by JSON punctuation or digits (a mutation test's edit); rng: the generator's
 * state, advanced. */
void test_mutate_json(char *m, const char *text, size_t n, size_t from, uint32_t *rng);

#endif
