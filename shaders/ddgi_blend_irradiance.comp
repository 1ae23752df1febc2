#version 460
/* DDGI probe blend of the irradiance atlas: shaders/ddgi_blend.glsl */
#extension GL_GOOGLE_include_directive : require
#define DDGI_BLEND_IRRADIANCE 1
#include "ddgi_blend.glsl"
