#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
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

char *test_read_text(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *s = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 && (s = malloc((size_t)n + 1))) {
        size_t got = fread(s, 1, (size_t)n, f);
        s[got] = '\0';
        if (len) *len = got;
    }
    fclose(f);
    return s;
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

/* A cube [-1,1]^3 with each face split into g x g cells of two triangles, outward CCW. */
uint32_t test_make_cube(float *pos, int g)
{
    uint32_t n = 0;
    for (int axis = 0; axis < 3; axis++) {
        for (int side = -1; side <= 1; side += 2) {
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int i = 0; i < g; i++) {
                for (int j = 0; j < g; j++) {
                    float p[4][3];
                    for (int c = 0; c < 4; c++) {
                        int ii = i + (c == 1 || c == 2), jj = j + (c >= 2);
                        p[c][axis] = (float)side;
                        p[c][u] = -1.0f + 2.0f * (float)ii / (float)g;
                        p[c][v] = -1.0f + 2.0f * (float)jj / (float)g;
                    }
                    /* (u, v, axis) is right-handed: CCW in (u, v) faces +axis */
                    int order[2][3] = {{0, 1, 2}, {0, 2, 3}};
                    for (int t = 0; t < 2; t++) {
                        for (int k = 0; k < 3; k++) {
                            int kk = side > 0 ? order[t][k] : order[t][2 - k];
                            memcpy(pos + 9 * n + 3 * k, p[kk], 3 * sizeof(float));
                        }
                        n++;
                    }
                }
            }
        }
    }
    return n;
}

/* ---- writing test files (glTF JSON with embedded buffers) ---- */

char *test_xprintf(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    char *s = malloc((size_t)n + 1);
    va_start(ap, fmt);
    vsnprintf(s, (size_t)n + 1, fmt, ap);
    va_end(ap);
    return s;
}

char *test_base64(const uint8_t *p, size_t n)
{
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc(n / 3 * 4 + 8), *o = out;
    size_t i = 0;
    for (; i + 2 < n; i += 3) {
        uint32_t v = (uint32_t)p[i] << 16 | (uint32_t)p[i + 1] << 8 | p[i + 2];
        *o++ = tab[v >> 18], *o++ = tab[(v >> 12) & 63], *o++ = tab[(v >> 6) & 63],
        *o++ = tab[v & 63];
    }
    if (i < n) {
        uint32_t v = (uint32_t)p[i] << 16 | (i + 1 < n ? (uint32_t)p[i + 1] << 8 : 0);
        *o++ = tab[v >> 18], *o++ = tab[(v >> 12) & 63];
        *o++ = i + 1 < n ? tab[(v >> 6) & 63] : '=';
        *o++ = '=';
    }
    *o = '\0';
    return out;
}

/* Test JSON is written with single quotes; this turns them into double quotes. */
char *test_jq(const char *s)
{
    char *d = malloc(strlen(s) + 1);
    for (size_t i = 0;; i++) {
        d[i] = s[i] == '\'' ? '"' : s[i];
        if (!s[i]) break;
    }
    return d;
}

void test_mutate_json(char *m, const char *text, size_t n, size_t from, uint32_t *rng)
{
    static const char alphabet[] = "0123456789-.e[]{},:\"9";
    memcpy(m, text, n + 1);
    int edits = 1 + (int)((*rng >> 8) % 3);
    for (int e = 0; e < edits && from < n; e++) {
        *rng = *rng * 1664525u + 1013904223u;
        size_t at = from + (*rng >> 4) % (n - from);
        *rng = *rng * 1664525u + 1013904223u;
        m[at] = alphabet[(*rng >> 16) % (sizeof alphabet - 1)];
    }
}
