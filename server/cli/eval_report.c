#include "server/cli/eval_report.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void eval_mark_pareto(eval_row *rows, unsigned n)
{
    for (unsigned i = 0; i < n; i++) {
        rows[i].pareto = true;
        for (unsigned j = 0; j < n && rows[i].pareto; j++) {
            if (j == i || strcmp(rows[i].scene, rows[j].scene) != 0) continue;
            bool faster = rows[j].gpu_ms <= rows[i].gpu_ms,
                 better = rows[j].err.rel_mse <= rows[i].err.rel_mse;
            bool strictly =
                rows[j].gpu_ms < rows[i].gpu_ms || rows[j].err.rel_mse < rows[i].err.rel_mse;
            if (faster && better && strictly) rows[i].pareto = false;
        }
    }
}

bool eval_write_csv(const char *path, const eval_row *rows, unsigned n)
{
    FILE *f = fopen(path, "w");
    if (!f) return false;
    fprintf(
        f,
        "scene,config,mode,probes_x,probes_y,probes_z,rays,updates,hysteresis,gpu_ms,rmse,rel_mse,"
        "smape,mean_lum_bias,p99_abs,non_finite,reference_noise_rel_mse,reference_ms,pareto,"
        "sleep_ms,slept\n");
    for (unsigned i = 0; i < n; i++) {
        const eval_row *r = &rows[i];
        fprintf(f,
                "%s,%s,%s,%u,%u,%u,%u,%u,%.2f,%.4f,%.6g,%.6g,%.6g,%.6g,%.6g,%zu,%.6g,%.3f,%d,%.3f,"
                "%d\n",
                r->scene, r->config, r->mode, r->probes[0], r->probes[1], r->probes[2], r->rays,
                r->updates, r->hysteresis, r->gpu_ms, r->err.rmse, r->err.rel_mse, r->err.smape,
                r->err.mean_lum_bias, r->err.p99_abs, r->err.non_finite, r->noise_rel_mse,
                r->ref_ms, r->pareto ? 1 : 0, r->sleep_ms, r->slept ? 1 : 0);
    }
    return fclose(f) == 0;
}

static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"' || *s == '\\') fputc('\\', f);
        if ((unsigned char)*s < 0x20)
            fprintf(f, "\\u%04x", *s);
        else
            fputc(*s, f);
    }
    fputc('"', f);
}

/* JSON has no NaN or Infinity: write null for them. */
static void json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.6g", v);
    else
        fputs("null", f);
}

bool eval_write_json(const char *path, const eval_row *rows, unsigned n, const char *device,
                     unsigned width, unsigned height, unsigned ref_spp)
{
    FILE *f = fopen(path, "w");
    if (!f) return false;
    fprintf(f, "{\n  \"device\": ");
    json_str(f, device);
    fprintf(f, ",\n  \"width\": %u, \"height\": %u, \"reference_spp\": %u,\n  \"rows\": [\n", width,
            height, ref_spp);
    for (unsigned i = 0; i < n; i++) {
        const eval_row *r = &rows[i];
        fprintf(f, "    {\"scene\": ");
        json_str(f, r->scene);
        fprintf(f, ", \"expect\": ");
        json_str(f, r->expect);
        fprintf(f, ", \"config\": ");
        json_str(f, r->config);
        fprintf(f, ", \"mode\": ");
        json_str(f, r->mode);
        fprintf(f,
                ", \"probes\": [%u, %u, %u], \"rays\": %u, \"updates\": %u, "
                "\"hysteresis\": %.2f, \"gpu_ms\": ",
                r->probes[0], r->probes[1], r->probes[2], r->rays, r->updates, r->hysteresis);
        json_num(f, r->gpu_ms);
        const double vals[] = {r->err.rmse,    r->err.rel_mse,   r->err.smape,
                               r->err.mean_lum_bias, r->err.p99_abs, r->noise_rel_mse,
                               r->ref_ms,      r->sleep_ms};
        const char *names[] = {"rmse",          "rel_mse", "smape",
                               "mean_lum_bias", "p99_abs", "reference_noise_rel_mse",
                               "reference_ms",  "sleep_ms"};
        for (int k = 0; k < 8; k++) {
            fprintf(f, ", \"%s\": ", names[k]);
            json_num(f, vals[k]);
        }
        fprintf(f, ", \"slept\": %s, \"non_finite\": %zu, \"pareto\": %s}%s\n",
                r->slept ? "true" : "false", r->err.non_finite, r->pareto ? "true" : "false",
                i + 1 < n ? "," : "");
    }
    fprintf(f, "  ]\n}\n");
    return fclose(f) == 0;
}

void eval_print_table(FILE *f, const eval_row *rows, unsigned n)
{
    fprintf(f, "%-20s %-34s %9s %11s %10s %9s %9s %6s %s\n", "scene", "config", "GPU ms",
            "relMSE", "RMSE", "bias", "p99", "front", "to sleep");
    for (unsigned i = 0; i < n; i++) {
        const eval_row *r = &rows[i];
        char sleep[48] = "";
        if (strcmp(r->mode, "default") == 0)
            snprintf(sleep, sizeof sleep, "%s%u updates, %.1f GPU ms", r->slept ? "" : "NOT: ",
                     r->updates, r->sleep_ms);
        fprintf(f, "%-20s %-34s %9.3f %11.4g %10.4g %+8.1f%% %9.4g %6s %s\n", r->scene, r->config,
                r->gpu_ms, r->err.rel_mse, r->err.rmse, 100 * r->err.mean_lum_bias, r->err.p99_abs,
                r->pareto ? "*" : "", sleep);
    }
}

static const char *mode_colour(const char *mode)
{
    if (strcmp(mode, "ddgi") == 0) return "#1f77b4";
    if (strcmp(mode, "classic") == 0) return "#ff7f0e";
    if (strcmp(mode, "default") == 0) return "#2ca02c";
    return "#7f7f7f";
}

bool eval_write_svg(const char *path, const eval_row *rows, unsigned n, const char *device)
{
    /* one panel per scene, 3 per row; x: GPU ms (log), y: relMSE (log) */
    const char *scenes[64];
    unsigned ns = 0;
    for (unsigned i = 0; i < n && ns < 64; i++) {
        unsigned k = 0;
        while (k < ns && strcmp(scenes[k], rows[i].scene) != 0)
            k++;
        if (k == ns) scenes[ns++] = rows[i].scene;
    }
    const int pw = 360, ph = 260, cols = 3, ml = 58, mb = 40, mt = 28, mr = 12;
    int rows_n = (int)((ns + cols - 1) / cols);
    FILE *f = fopen(path, "w");
    if (!f) return false;
    int W = cols * pw, H = rows_n * ph + 40;
    fprintf(f,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
            "font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%%\" height=\"100%%\" "
            "fill=\"white\"/>\n",
            W, H);
    fprintf(f,
            "<text x=\"10\" y=\"18\" font-size=\"14\">probecast: GPU time per frame vs error "
            "against the path-traced reference (%s); filled = Pareto front; "
            "<tspan fill=\"#1f77b4\">ddgi</tspan> <tspan fill=\"#ff7f0e\">classic</tspan> "
            "<tspan fill=\"#7f7f7f\">direct</tspan></text>\n",
            device);
    for (unsigned s = 0; s < ns; s++) {
        int ox = (int)(s % cols) * pw, oy = 40 + (int)(s / cols) * ph;
        double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
        for (unsigned i = 0; i < n; i++) {
            if (strcmp(rows[i].scene, scenes[s]) != 0) continue;
            double x = fmax(rows[i].gpu_ms, 1e-3), y = fmax(rows[i].err.rel_mse, 1e-8);
            xmin = fmin(xmin, x), xmax = fmax(xmax, x), ymin = fmin(ymin, y), ymax = fmax(ymax, y);
        }
        double lx0 = floor(log10(xmin)), lx1 = ceil(log10(xmax)), ly0 = floor(log10(ymin)),
               ly1 = ceil(log10(ymax));
        if (lx1 <= lx0) lx1 = lx0 + 1;
        if (ly1 <= ly0) ly1 = ly0 + 1;
        int x0 = ox + ml, x1 = ox + pw - mr, y0 = oy + ph - mb, y1 = oy + mt;
#define PX(v) (x0 + (log10(fmax(v, 1e-3)) - lx0) / (lx1 - lx0) * (x1 - x0))
#define PY(v) (y0 - (log10(fmax(v, 1e-8)) - ly0) / (ly1 - ly0) * (y0 - y1))
        fprintf(f, "<text x=\"%d\" y=\"%d\" font-size=\"12\" font-weight=\"bold\">%s</text>\n", x0,
                oy + 16, scenes[s]);
        fprintf(
            f,
            "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"none\" stroke=\"#999\"/>\n",
            x0, y1, x1 - x0, y0 - y1);
        for (double e = lx0; e <= lx1; e++)
            fprintf(f, "<text x=\"%.1f\" y=\"%d\" text-anchor=\"middle\">%g</text>\n",
                    x0 + (e - lx0) / (lx1 - lx0) * (x1 - x0), y0 + 14, pow(10, e));
        for (double e = ly0; e <= ly1; e++)
            fprintf(f, "<text x=\"%d\" y=\"%.1f\" text-anchor=\"end\">1e%g</text>\n", x0 - 4,
                    y0 - (e - ly0) / (ly1 - ly0) * (y0 - y1) + 4, e);
        fprintf(f, "<text x=\"%d\" y=\"%d\" text-anchor=\"middle\">GPU ms per frame</text>\n",
                (x0 + x1) / 2, y0 + 30);
        fprintf(f,
                "<text x=\"%d\" y=\"%d\" transform=\"rotate(-90 %d %d)\" "
                "text-anchor=\"middle\">relMSE</text>\n",
                ox + 14, (y0 + y1) / 2, ox + 14, (y0 + y1) / 2);
        /* Pareto front as a staircase through the front's points, by time */
        unsigned front[256], nf = 0;
        for (unsigned i = 0; i < n && nf < 256; i++)
            if (rows[i].pareto && strcmp(rows[i].scene, scenes[s]) == 0) front[nf++] = i;
        for (unsigned a = 0; a < nf; a++)
            for (unsigned b = a + 1; b < nf; b++)
                if (rows[front[b]].gpu_ms < rows[front[a]].gpu_ms) {
                    unsigned t = front[a];
                    front[a] = front[b], front[b] = t;
                }
        if (nf > 1) {
            fprintf(f, "<polyline fill=\"none\" stroke=\"#2ca02c\" stroke-width=\"1.5\" points=\"");
            for (unsigned a = 0; a < nf; a++)
                fprintf(f, "%.1f,%.1f ", PX(rows[front[a]].gpu_ms), PY(rows[front[a]].err.rel_mse));
            fprintf(f, "\"/>\n");
        }
        for (unsigned i = 0; i < n; i++) {
            if (strcmp(rows[i].scene, scenes[s]) != 0) continue;
            const char *c = mode_colour(rows[i].mode);
            fprintf(f,
                    "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"4\" stroke=\"%s\" fill=\"%s\"><title>%s: "
                    "%.3f ms, relMSE %.4g</title></circle>\n",
                    PX(rows[i].gpu_ms), PY(rows[i].err.rel_mse), c, rows[i].pareto ? c : "white",
                    rows[i].config, rows[i].gpu_ms, rows[i].err.rel_mse);
        }
        if (rows[0].noise_rel_mse > 0) {
            for (unsigned i = 0; i < n; i++)
                if (strcmp(rows[i].scene, scenes[s]) == 0 && rows[i].noise_rel_mse > 0) {
                    double y = PY(rows[i].noise_rel_mse);
                    if (y < y1 || y > y0) break; /* outside this panel's range */
                    fprintf(
                        f,
                        "<line x1=\"%d\" x2=\"%d\" y1=\"%.1f\" y2=\"%.1f\" stroke=\"#d62728\" "
                        "stroke-dasharray=\"4 3\"><title>reference noise floor</title></line>\n",
                        x0, x1, y, y);
                    break;
                }
        }
#undef PX
#undef PY
    }
    fprintf(f, "</svg>\n");
    return fclose(f) == 0;
}

bool eval_read_csv(const char *path, eval_row **rows_out, unsigned *n_out)
{
    FILE *f = fopen(path, "r");
    if (!f) return false;
    char line[1024];
    unsigned n = 0, cap = 0;
    eval_row *rows = NULL;
    bool ok = fgets(line, sizeof line, f) != NULL; /* header */
    while (ok && fgets(line, sizeof line, f)) {
        if (n == cap) {
            cap = cap ? cap * 2 : 64;
            rows = realloc(rows, cap * sizeof *rows);
            if (!rows) abort();
        }
        eval_row *r = &rows[n];
        memset(r, 0, sizeof *r);
        int pareto = 0, slept = 0;
        int got = sscanf(line,
                         "%47[^,],%63[^,],%15[^,],%u,%u,%u,%u,%u,%f,%lf,%lf,%lf,%lf,%lf,%lf,%zu,%lf,"
                         "%lf,%d,%lf,%d",
                         r->scene, r->config, r->mode, &r->probes[0], &r->probes[1],
                         &r->probes[2], &r->rays, &r->updates, &r->hysteresis, &r->gpu_ms,
                         &r->err.rmse, &r->err.rel_mse, &r->err.smape, &r->err.mean_lum_bias,
                         &r->err.p99_abs, &r->err.non_finite, &r->noise_rel_mse, &r->ref_ms,
                         &pareto, &r->sleep_ms, &slept);
        if (got != 19 && got != 21) ok = false; /* 19: written before the default row */
        r->pareto = pareto != 0;
        r->slept = slept != 0;
        n++;
    }
    fclose(f);
    if (!ok) {
        free(rows);
        return false;
    }
    *rows_out = rows;
    *n_out = n;
    return true;
}
