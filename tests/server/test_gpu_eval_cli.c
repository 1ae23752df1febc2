/* probecast eval end to end on lavapipe (the executable, as a user runs it): the setting flags
 * eval does not sweep (--visibility-rays, --probe-relocation, --probe-paths) reach every GI row,
 * the default row included, and the rows say so; without them the rows are the defaults. They
 * were parsed and then ignored. A flag beyond its range is refused before any rendering. The
 * case is hard:mirrored (a plane and a point light: fast; its GI is exactly zero). The view
 * options (--reflections, --shadow-cull) label the rows too. */
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "test_util.h"

/* Runs probecast eval with the extra options into a fresh directory; returns eval.csv's text
 * (NULL on failure; the caller frees) and the exit status in *status. */
static char *eval(const char *options, int *status)
{
    char dir[512];
    snprintf(dir, sizeof dir, "%s", test_tmp_path("eval-cli"));
    char cmd[2048];
    snprintf(cmd, sizeof cmd,
             "rm -rf '%s' && '%s' eval --cases mirrored --materials lambert --width 16 "
             "--height 16 --ref-spp 4 --rays 16 --updates 2 --density 1 --hysteresis 0.9 "
             "--no-noise-floor --out '%s' %s 2>&1",
             dir, PROBECAST_EXE, dir, options);
    FILE *p = popen(cmd, "r");
    if (!p) return NULL;
    char out[8192];
    size_t n = fread(out, 1, sizeof out - 1, p);
    out[n] = '\0';
    *status = pclose(p);
    if (!WIFEXITED(*status) || WEXITSTATUS(*status) != 0) {
        printf("%s\n%s\n", cmd, out);
        return NULL;
    }
    char csv[600];
    snprintf(csv, sizeof csv, "%s/eval.csv", dir);
    return test_read_text(csv, NULL);
}

/* The number of rows of csv whose line contains both a and b. */
static unsigned rows_with(const char *csv, const char *a, const char *b)
{
    unsigned n = 0;
    for (const char *line = csv; line && *line;) {
        const char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line) : strlen(line);
        char buf[1024];
        snprintf(buf, sizeof buf, "%.*s", (int)(len < sizeof buf ? len : sizeof buf - 1), line);
        n += strstr(buf, a) && strstr(buf, b);
        line = end ? end + 1 : NULL;
    }
    return n;
}

int main(void)
{
    int status = 0;
    char *plain = eval("", &status);
    CHECKF(plain != NULL, "eval without flags failed (status %d)", status);
    char *flagged = eval("--probe-paths 2 --visibility-rays probes --probe-relocation on", &status);
    CHECKF(flagged != NULL, "eval with the flags failed (status %d)", status);
    if (plain && flagged) {
        /* rows: direct, classic, default, one ddgi setting */
        CHECKF(rows_with(plain, "mirrored", "default 8x1x8 r256 sleeps@") == 1 &&
                   rows_with(plain, "mirrored", "ddgi 8x1x8 r16 u2 h0.90") == 1,
               "the default rows:\n%s", plain);
        CHECKF(rows_with(plain, "mirrored", "paths") == 0, "no flag, no label:\n%s", plain);
        const char *label = " vis-probes relocate paths2";
        CHECKF(rows_with(flagged, "default 8x1x8 r256 vis-probes relocate paths2", "sleeps@") == 1,
               "the default row with the flags:\n%s", flagged);
        CHECKF(rows_with(flagged, "ddgi 8x1x8 r16 u2 h0.90", label) == 1,
               "the ddgi row with the flags:\n%s", flagged);
        CHECKF(rows_with(flagged, "classic", label) == 1, "the classic row:\n%s", flagged);
    }
    free(plain), free(flagged);
    /* the view options label the rows (hard:mirrored has nothing glossy to reflect: that
     * --reflections off reaches the frames would show on hard:glossy, whose default row takes
     * lavapipe minutes to converge) */
    char *views = eval("--reflections off --shadow-cull off", &status);
    CHECKF(views && rows_with(views, "ddgi 8x1x8 r16 u2 h0.90", " cull-off refl-off") == 1,
           "the ddgi row with the view options:\n%s", views ? views : "(failed)");
    free(views);
    /* refused before rendering: exit status 2 */
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s' eval --cases mirrored --probe-paths 9 >/dev/null 2>&1",
             PROBECAST_EXE);
    int s = system(cmd);
    CHECKF(WIFEXITED(s) && WEXITSTATUS(s) == 2, "--probe-paths 9: status %d", s);
    return test_finish();
}
