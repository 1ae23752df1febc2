#version 460
/* DDGI probe blend of the distance atlas: shaders/ddgi_blend.glsl */
#extension GL_GOOGLE_include_directive : require
#define DDGI_BLEND_IRRADIANCE 0
#include "ddgi_blend.glsl"
