/* brdf_reference.h: the glTF 2.0 metallic-roughness BRDF written again from the specification's
 * Appendix B, in C and apart from shaders/brdf.glsl, as an analytic reference for the tests: its
 * directional albedo by numerical integration, and the radiance bounds of a closed furnace made
 * of it. */
#ifndef TEST_BRDF_REFERENCE_H
#define TEST_BRDF_REFERENCE_H

/* Directional albedo A(mu) = integral over the hemisphere of f(v, l) N.L dl for a view at
 * cos(theta_v) = mu, grey base colour `base` (dielectric specular 1: glTF's default). Midpoint
 * rule over (cos theta_l, phi) with n x n cells. */
double test_brdf_albedo(double base, double metallic, double roughness, double mu, int n);

/* A closed furnace whose every surface emits le and reflects with this BRDF holds radiance
 * le / (1 - A) when A is the albedo at its view angles. Gives that radiance for the albedos at
 * mu = 1 and mu = 0.5 (views within 60 degrees of the normal, where a camera inside a furnace
 * sees most of its surfaces and most light is exchanged): lo <= hi. */
void test_furnace_bounds(double base, double metallic, double roughness, double le, double *lo,
                         double *hi);

#endif
