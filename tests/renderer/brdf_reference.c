/* brdf_reference.c: Appendix B's BRDF and its albedo, for the tests (brdf_reference.h). */
#include "brdf_reference.h"

#include <math.h>

static double brdf(double base, double metallic, double roughness, const double v[3],
                   const double l[3])
{
    double a = roughness < 0.045 ? 0.045 * 0.045 : roughness * roughness, a2 = a * a;
    double h[3] = {v[0] + l[0], v[1] + l[1], v[2] + l[2]};
    double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (int k = 0; k < 3; k++)
        h[k] /= hl;
    double nh = h[2], nl = l[2], nv = v[2] > 1e-4 ? v[2] : 1e-4;
    double vh = v[0] * h[0] + v[1] * h[1] + v[2] * h[2];
    if (vh < 0) vh = 0;
    double dd = nh * nh * (a2 - 1) + 1;
    double d = a2 / (M_PI * dd * dd);
    double vis = 0.5 / (nl * sqrt(nv * nv * (1 - a2) + a2) + nv * sqrt(nl * nl * (1 - a2) + a2));
    double w = pow(1 - vh, 5), spec = d * vis;
    double f_dielectric = 0.04 + 0.96 * w;
    double dielectric = (1 - f_dielectric) * base / M_PI + f_dielectric * spec;
    double metal = spec * (base + (1 - base) * w);
    return (1 - metallic) * dielectric + metallic * metal;
}

double test_brdf_albedo(double base, double metallic, double roughness, double mu, int n)
{
    double v[3] = {sqrt(1 - mu * mu), 0, mu}, sum = 0;
    for (int i = 0; i < n; i++) {
        double ct = (i + 0.5) / n, st = sqrt(1 - ct * ct);
        for (int j = 0; j < n; j++) {
            double phi = 2 * M_PI * (j + 0.5) / n;
            double l[3] = {st * cos(phi), st * sin(phi), ct};
            sum += brdf(base, metallic, roughness, v, l) * ct;
        }
    }
    return sum * (2 * M_PI / n) / n; /* dl = d(cos theta) d(phi) */
}

void test_furnace_bounds(double base, double metallic, double roughness, double le, double *lo,
                         double *hi)
{
    double a1 = test_brdf_albedo(base, metallic, roughness, 1.0, 256);
    double a05 = test_brdf_albedo(base, metallic, roughness, 0.5, 256);
    double x = le / (1 - a1), y = le / (1 - a05);
    *lo = x < y ? x : y;
    *hi = x < y ? y : x;
}
