/* bench_frame.c: the JPEG benchmark's input frames (see bench_frame.h). */
#include "bench_frame.h"

#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double clamp01(double v)
{
    return v < 0 ? 0 : v > 1 ? 1 : v;
}

uint8_t *bench_make_frame(unsigned w, unsigned h)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    if (!p) abort();
    static const double sph[3][4] = {
        {-1.3, 0.6, 5.0, 0.6}, {0.4, 0.9, 6.5, 0.9}, {1.6, 0.45, 4.2, 0.45}};
    static const double col[3][3] = {{0.85, 0.3, 0.25}, {0.3, 0.6, 0.9}, {0.9, 0.85, 0.4}};
    const double L[3] = {-0.48, 0.8, -0.36}; /* towards the light */
    uint32_t seed = 12345;
    double aspect = (double)w / h;
    for (unsigned y = 0; y < h; y++) {
        for (unsigned x = 0; x < w; x++) {
            double d[3] = {((x + 0.5) / w * 2 - 1) * aspect * 0.6, (1 - (y + 0.5) / h * 2) * 0.6,
                           1};
            double n = sqrt(d[0] * d[0] + d[1] * d[1] + 1);
            d[0] /= n, d[1] /= n, d[2] /= n;
            const double o[3] = {0, 1.2, 0};
            double c[3], best = 1e30;
            int hit = -1;
            for (int s = 0; s < 3; s++) {
                double oc[3] = {o[0] - sph[s][0], o[1] - sph[s][1], o[2] - sph[s][2]};
                double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
                double cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - sph[s][3] * sph[s][3];
                double disc = b * b - cc;
                if (disc > 0 && -b - sqrt(disc) < best && -b - sqrt(disc) > 0) {
                    best = -b - sqrt(disc);
                    hit = s;
                }
            }
            double tf = d[1] < 0 ? -o[1] / d[1] : 1e30;
            if (hit >= 0 && best < tf) {
                double q[3], nn[3];
                for (int k = 0; k < 3; k++) {
                    q[k] = o[k] + best * d[k];
                    nn[k] = (q[k] - sph[hit][k]) / sph[hit][3];
                }
                double lam = clamp01(nn[0] * L[0] + nn[1] * L[1] + nn[2] * L[2]);
                double spec = pow(clamp01(nn[1] * 0.7 + nn[2] * -0.7), 40);
                for (int k = 0; k < 3; k++)
                    c[k] = col[hit][k] * (0.12 + 0.85 * lam) + 0.5 * spec;
            } else if (tf < 1e29) {
                double fx = o[0] + tf * d[0], fz = o[2] + tf * d[2];
                int check = ((int)floor(fx) + (int)floor(fz)) & 1;
                double base = check ? 0.75 : 0.35, shadow = 1;
                for (int s = 0; s < 3; s++) { /* soft shadow: distance to the sphere's foot */
                    double dx = fx - (sph[s][0] - 0.6 * sph[s][1]);
                    double dz = fz - (sph[s][2] + 0.45 * sph[s][1]);
                    double r = sqrt(dx * dx + dz * dz) / sph[s][3];
                    shadow *= 0.35 + 0.65 * clamp01((r - 0.6) / 0.8);
                }
                double fog = exp(-tf * 0.04);
                for (int k = 0; k < 3; k++)
                    c[k] = (base * shadow * (k == 2 ? 0.9 : 1.0)) * fog + (1 - fog) * 0.7;
            } else {
                double t = clamp01(d[1] * 2);
                c[0] = 0.75 - 0.45 * t, c[1] = 0.82 - 0.35 * t, c[2] = 0.95 - 0.1 * t;
            }
            uint8_t *px = p + ((size_t)y * w + x) * 4;
            for (int k = 0; k < 3; k++) {
                seed = seed * 1664525u + 1013904223u;
                double grain = ((seed >> 24) % 9) - 4.0;
                double v = 255 * pow(clamp01(c[k]), 1 / 2.2) + grain;
                px[k] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            px[3] = 255;
        }
    }
    return p;
}

uint8_t *bench_read_image(const char *path, unsigned *w, unsigned *h)
{
    size_t n = strlen(path);
    if (n > 4 && strcmp(path + n - 4, ".png") == 0) {
        png_image img;
        memset(&img, 0, sizeof img);
        img.version = PNG_IMAGE_VERSION;
        if (!png_image_begin_read_from_file(&img, path)) return NULL;
        img.format = PNG_FORMAT_RGBA;
        uint8_t *p = malloc(PNG_IMAGE_SIZE(img));
        if (!p || !png_image_finish_read(&img, NULL, p, 0, NULL)) {
            free(p);
            png_image_free(&img);
            return NULL;
        }
        *w = img.width, *h = img.height;
        return p;
    }
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned maxv = 0;
    uint8_t *p = NULL;
    if (fscanf(f, "P6 %u %u %u", w, h, &maxv) == 3 && maxv == 255 && fgetc(f) != EOF && *w && *h) {
        size_t px = (size_t)*w * *h;
        uint8_t *rgb = malloc(px * 3);
        p = malloc(px * 4);
        if (rgb && p && fread(rgb, 3, px, f) == px) {
            for (size_t i = 0; i < px; i++) {
                memcpy(p + 4 * i, rgb + 3 * i, 3);
                p[4 * i + 3] = 255;
            }
        } else {
            free(p);
            p = NULL;
        }
        free(rgb);
    }
    fclose(f);
    return p;
}

uint8_t *bench_resample(const uint8_t *src, unsigned sw, unsigned sh, unsigned w, unsigned h)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    if (!p) abort();
    for (unsigned y = 0; y < h; y++) {
        double fy = (y + 0.5) * sh / h - 0.5;
        int y0 = fy < 0 ? 0 : (int)fy, y1 = y0 + 1 < (int)sh ? y0 + 1 : y0;
        double ty = fy < 0 ? 0 : fy - y0;
        for (unsigned x = 0; x < w; x++) {
            double fx = (x + 0.5) * sw / w - 0.5;
            int x0 = fx < 0 ? 0 : (int)fx, x1 = x0 + 1 < (int)sw ? x0 + 1 : x0;
            double tx = fx < 0 ? 0 : fx - x0;
            for (int c = 0; c < 4; c++) {
                double a = src[((size_t)y0 * sw + x0) * 4 + c] * (1 - tx) +
                           src[((size_t)y0 * sw + x1) * 4 + c] * tx;
                double b = src[((size_t)y1 * sw + x0) * 4 + c] * (1 - tx) +
                           src[((size_t)y1 * sw + x1) * 4 + c] * tx;
                p[((size_t)y * w + x) * 4 + c] = (uint8_t)(a * (1 - ty) + b * ty + 0.5);
            }
        }
    }
    return p;
}
