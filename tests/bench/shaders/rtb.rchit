#version 460
/* rtb.rchit: closest hit of rt_yardstick's driver rays: the hit distance. */
#extension GL_EXT_ray_tracing : require
layout(location = 0) rayPayloadInEXT float hit_t;
void main() { hit_t = gl_HitTEXT; }
