/* The command line made from the settings table (server/api/settings.h): the settings flags of
 * serve, render and eval in their parsers, at every setting's bounds and just beyond, and as the
 * probecast program runs them (its --help and its refusals: parsing only, no daemon, no GPU).
 * The table itself, JSON and the OpenAPI schema: test_settings_table.c. */
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "server/api/settings.h"
#include "test_util.h"

static int dims(const srv_setting_info *d)
{
    return d->type == SRV_TYPE_FLOAT3 || d->type == SRV_TYPE_UINT3 ? 3 : 1;
}

/* ---- command line ----------------------------------------------------------------------- */

static int run_flags(char **argv, int argc, srv_settings *s, unsigned *given)
{
    for (int i = 0; i < argc; i++) {
        int r = srv_settings_parse_flag("test", SRV_CLI_SERVE, argc, argv, &i, s, given);
        if (r <= 0) return r;
    }
    return 1;
}

static void test_cli(void)
{
    srv_settings s;
    srv_settings_defaults(&s);
    unsigned given = 0;
    char *ok[] = {"--width",
                  "64",
                  "--height",
                  "48",
                  "--probes",
                  "2,3,4",
                  "--gi",
                  "pathtrace",
                  "--hysteresis",
                  "0",
                  "--sky",
                  "1,0.5,0",
                  "--exposure",
                  "-2",
                  "--rays",
                  "16",
                  "--max-fps",
                  "60",
                  "--quality-interactive",
                  "50",
                  "--quality-still",
                  "95",
                  "--probe-spacing",
                  "0.5"};
    int n = (int)(sizeof ok / sizeof ok[0]);
    CHECK(run_flags(ok, n, &s, &given) == 1);
    CHECK(s.width == 64 && s.height == 48 && s.probe_counts[1] == 3 &&
          s.gi_mode == SRV_GI_PATHTRACE && s.hysteresis == 0 && s.sky[1] == 0.5f);
    CHECK(s.exposure_ev == -2 && s.rays_per_probe == 16 && s.max_fps == 60);
    CHECK(s.quality_interactive == 50 && s.quality_still == 95 && s.probe_spacing == 0.5f);
    CHECK(given ==
          (SRV_SET_WIDTH | SRV_SET_HEIGHT | SRV_SET_PROBE_COUNTS | SRV_SET_GI_MODE |
           SRV_SET_HYSTERESIS | SRV_SET_SKY | SRV_SET_EXPOSURE | SRV_SET_RAYS | SRV_SET_MAX_FPS |
           SRV_SET_QUALITY_INTERACTIVE | SRV_SET_QUALITY_STILL | SRV_SET_PROBE_SPACING));

    /* not a setting flag, or not one of this command's: left to the caller */
    char *other[] = {"--token", "x"};
    int i = 0;
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, other, &i, &s, &given) == 0 && i == 0);
    char *render_only[] = {"--tonemap", "clamp"};
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, render_only, &i, &s, &given) == 0);
    CHECK(srv_settings_parse_flag("test", SRV_CLI_RENDER, 2, render_only, &i, &s, &given) == 1 &&
          i == 1 && s.tonemap == PC_TONEMAP_CLAMP);

    fprintf(stderr, "(the messages below are expected)\n");
    const char *bad[][2] = {
        {"--width", "8"},    {"--width", "64.5"},  {"--width", "-64"}, {"--probes", "0,2,2"},
        {"--probes", "2,2"}, {"--gi", "full"},     {"--rays", "0"},    {"--hysteresis", "1"},
        {"--sky", "-1,0,0"}, {"--exposure", "30"}, {"--max-fps", "x"}, {"--sky", "1,2,3,"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        srv_settings t = s;
        unsigned g = 0;
        char *argv[] = {(char *)bad[k][0], (char *)bad[k][1]};
        i = 0;
        CHECKF(srv_settings_parse_flag("test", SRV_CLI_SERVE, 2, argv, &i, &t, &g) == -1 &&
                   g == 0 && memcmp(&t, &s, sizeof t) == 0,
               "%s %s accepted", bad[k][0], bad[k][1]);
    }
    char *missing[] = {"--rays"};
    i = 0;
    CHECK(srv_settings_parse_flag("test", SRV_CLI_SERVE, 1, missing, &i, &s, &given) == -1);

    /* the usage lines: every flag once, defaults from the table */
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    srv_settings_print_usage(f, SRV_CLI_SERVE);
    fclose(f);
    for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
        const srv_setting_info *d = srv_setting_at(k);
        if (!(d->cli & SRV_CLI_SERVE)) continue;
        char head[64];
        snprintf(head, sizeof head, "  %s ", d->flag);
        CHECKF(strstr(text, head) != NULL, "usage lacks %s", d->flag);
    }
    CHECKF(strstr(text, "--hysteresis H") && strstr(text, "(default 0.97)"), "%s", text);
    CHECKF(strstr(text, "(default 256; 64 on a CPU device)"), "%s", text);
    CHECKF(strstr(text, "--gi off|classic|ddgi|pathtrace"), "%s", text);
    CHECKF(!strstr(text, "--tonemap"), "%s", text);
    free(text);
}

/* ---- the commands' flags: every setting of serve, render and eval at its bounds and beyond --- */

static const struct {
    const char *name;
    unsigned cli;
} commands[] = {{"serve", SRV_CLI_SERVE}, {"render", SRV_CLI_RENDER}, {"eval", SRV_CLI_EVAL}};

/* eval takes these as lists (cmd_eval.c, EVAL_SWEEPS) */
#define SWEEPS (SRV_SET_RAYS | SRV_SET_HYSTERESIS | SRV_SET_PROBE_COUNTS)

/* d's value x as the command line writes it (in every component); an ENUM's x beyond its names is
 * a name it lacks. */
static void cli_text(const srv_setting_info *d, double x, char *buf, size_t len)
{
    if (d->type == SRV_TYPE_ENUM)
        snprintf(buf, len, "%s", x >= 0 && x < d->name_count ? d->names[(unsigned)x] : "nope");
    else if (dims(d) == 3)
        snprintf(buf, len, "%.17g,%.17g,%.17g", x, x, x);
    else
        snprintf(buf, len, "%.17g", x);
}

/* Just beyond d's bound (still beyond it as a float). */
static double beyond(const srv_setting_info *d, bool above)
{
    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
    double bound = above ? d->max : d->min;
    double eps = fl ? 1e-3 * (1 + fabs(bound)) : 1;
    return above ? bound + eps : bound - eps;
}

/* The parsers as the commands call them: srv_settings_parse_flag for one value, and
 * srv_setting_parse_list for eval's sweeps. */
static void test_cli_bounds(void)
{
    for (unsigned c = 0; c < sizeof commands / sizeof commands[0]; c++) {
        for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
            const srv_setting_info *d = srv_setting_at(k);
            if (!(d->cli & commands[c].cli)) continue;
            char lo[96], hi[96], below[96], above[96];
            cli_text(d, d->min, lo, sizeof lo);
            cli_text(d, d->max, hi, sizeof hi);
            cli_text(d, beyond(d, false), below, sizeof below);
            cli_text(d, beyond(d, true), above, sizeof above);
            const char *values[4] = {lo, hi, below, above};
            for (int v = 0; v < 4; v++) {
                srv_settings s, before;
                srv_settings_defaults(&s);
                before = s;
                unsigned given = 0;
                char *argv[] = {(char *)d->flag, (char *)values[v]};
                int i = 0;
                int r = srv_settings_parse_flag(commands[c].name, commands[c].cli, 2, argv, &i, &s,
                                                &given);
                if (v < 2) {
                    CHECKF(r == 1 && given == d->bit, "%s %s %s refused", commands[c].name, d->flag,
                           values[v]);
                    /* the last component, as stored */
                    bool fl = d->type == SRV_TYPE_FLOAT || d->type == SRV_TYPE_FLOAT3;
                    const char *m = (const char *)&s + d->offset;
                    double got =
                        fl ? ((const float *)m)[dims(d) - 1] : ((const unsigned *)m)[dims(d) - 1];
                    double want = v == 0 ? d->min : d->max;
                    CHECKF(fl ? (float)got == (float)want : got == want, "%s %s: stored %g",
                           d->flag, values[v], got);
                } else {
                    CHECKF(r == -1 && given == 0 && memcmp(&s, &before, sizeof s) == 0,
                           "%s %s %s accepted", commands[c].name, d->flag, values[v]);
                }
            }
            /* a list of values, as eval sweeps them */
            if (commands[c].cli != SRV_CLI_EVAL || !(d->bit & SWEEPS)) continue;
            char sep = dims(d) == 3 ? ';' : ',', list[256];
            srv_settings out[8];
            unsigned n = 0;
            snprintf(list, sizeof list, "%s%c%s", lo, sep, hi);
            CHECKF(srv_setting_parse_list("eval", d, list, out, 8, &n) && n == 2, "%s %s refused",
                   d->flag, list);
            for (int v = 2; v < 4; v++) {
                snprintf(list, sizeof list, "%s%c%s", lo, sep, values[v]);
                CHECKF(!srv_setting_parse_list("eval", d, list, out, 8, &n), "%s %s accepted",
                       d->flag, list);
            }
            snprintf(list, sizeof list, "%s%c", lo, sep);
            CHECKF(!srv_setting_parse_list("eval", d, list, out, 8, &n), "%s %s", d->flag, list);
            CHECK(!srv_setting_parse_list("eval", d, "", out, 8, &n));
            CHECK(!srv_setting_parse_list("eval", d, list, out, 1, &n)); /* more than max */
        }
    }
    /* the values of a list, in order */
    srv_settings out[8];
    unsigned n = 0;
    const srv_setting_info *h = srv_setting_by_flag("--hysteresis", SRV_CLI_EVAL);
    CHECK(srv_setting_parse_list("eval", h, "0.85,0,0.999", out, 8, &n) && n == 3 &&
          out[0].hysteresis == 0.85f && out[1].hysteresis == 0 && out[2].hysteresis == 0.999f);
    CHECK(!srv_setting_parse_list("eval", h, "0.5,1", out, 8, &n));
    const srv_setting_info *p = srv_setting_by_flag("--probes", SRV_CLI_EVAL);
    CHECK(srv_setting_parse_list("eval", p, "2,3,4;0,0,0", out, 8, &n) && n == 2 &&
          out[0].probe_counts[2] == 4 && out[1].probe_counts[0] == 0);
    CHECK(!srv_setting_parse_list("eval", p, "2,3,4;0,1,1", out, 8, &n));
}

/* Runs the probecast program with args (NULL-terminated) and stderr to /dev/null; returns its
 * exit status (-1 when it did not exit), and its stdout in *out (caller frees) when out. */
static int run_probecast(const char *const *args, char **out)
{
    const char *argv[16] = {PROBECAST_EXE};
    for (int i = 0; args[i] && i < 14; i++)
        argv[i + 1] = args[i];
    int fd[2];
    if (pipe(fd) != 0) return -1;
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_WRONLY);
        dup2(fd[1], 1);
        dup2(null, 2);
        close(fd[0]);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(fd[1]);
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    char buf[4096];
    ssize_t got;
    while ((got = read(fd[0], buf, sizeof buf)) > 0)
        fwrite(buf, 1, (size_t)got, f);
    fclose(f);
    close(fd[0]);
    int status = 0;
    if (pid < 0 || waitpid(pid, &status, 0) != pid) status = -1;
    if (out)
        *out = text;
    else
        free(text);
    return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* The program itself: each command takes its settings' flags at their bounds and refuses them
 * beyond (the flags come before --help, which then ends the parse with status 0), refuses the
 * flags of settings it does not take, and its --help names every flag it takes. */
static void test_cli_programs(void)
{
    for (unsigned c = 0; c < sizeof commands / sizeof commands[0]; c++) {
        const char *cmd = commands[c].name;
        char *help = NULL;
        const char *args[] = {cmd, "--help", NULL};
        CHECKF(run_probecast(args, &help) == 0 && help, "%s --help", cmd);
        if (!help) continue;
        for (unsigned k = 0; k < SRV_SETTING_COUNT; k++) {
            const srv_setting_info *d = srv_setting_at(k);
            if (!d->flag) continue;
            bool takes = d->cli & commands[c].cli;
            bool list = commands[c].cli == SRV_CLI_EVAL && (d->bit & SWEEPS);
            char head[64];
            snprintf(head, sizeof head, "\n  %s ", d->flag);
            CHECKF(!strstr(help, head) == !takes, "%s --help %s %s", cmd, takes ? "lacks" : "shows",
                   d->flag);
            char lo[96], hi[96], below[96], above[96], value[200];
            cli_text(d, d->min, lo, sizeof lo);
            cli_text(d, d->max, hi, sizeof hi);
            cli_text(d, beyond(d, false), below, sizeof below);
            cli_text(d, beyond(d, true), above, sizeof above);
            const char *values[4] = {lo, hi, below, above};
            char sep = dims(d) == 3 ? ';' : ',';
            for (int v = 0; v < 4; v++) {
                if (list) /* a list of the lower bound and the value */
                    snprintf(value, sizeof value, "%s%c%s", lo, sep, values[v]);
                else
                    snprintf(value, sizeof value, "%s", values[v]);
                const char *run[] = {cmd, d->flag, value, "--help", NULL};
                int want = takes && v < 2 ? 0 : 2;
                int got = run_probecast(run, NULL);
                CHECKF(got == want, "probecast %s %s %s --help: exit %d, not %d", cmd, d->flag,
                       value, got, want);
                if (!takes) break; /* refused whatever the value */
            }
        }
        free(help);
    }
    /* the help of a sweep shows the list and eval's defaults; render's the table's */
    static const char *const shows[][4] = {
        {"eval", "--hysteresis H[,H...]", "(default 0.85,0.97)", "--probes X,Y,Z[;X,Y,Z...]"},
        {"render", "--hysteresis H ", "(default 0.97)", "--tonemap aces|clamp"},
    };
    for (unsigned c = 0; c < sizeof shows / sizeof shows[0]; c++) {
        char *help = NULL;
        const char *args[] = {shows[c][0], "--help", NULL};
        CHECK(run_probecast(args, &help) == 0 && help);
        for (int k = 1; help && k < 4; k++)
            CHECKF(strstr(help, shows[c][k]) != NULL, "%s --help lacks '%s'", shows[c][0],
                   shows[c][k]);
        free(help);
    }
    /* what the brief of issue 27 asked by hand */
    const char *h15[] = {"render", "--hysteresis", "1.5", "builtin:cornell", NULL};
    CHECK(run_probecast(h15, NULL) == 2);
}

int main(void)
{
    test_cli();
    test_cli_bounds();
    test_cli_programs();
    return test_finish();
}
