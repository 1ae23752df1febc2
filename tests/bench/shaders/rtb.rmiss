#version 460
/* rtb.rmiss: a miss of rt_yardstick's driver rays: -1. */
#extension GL_EXT_ray_tracing : require
layout(location = 0) rayPayloadInEXT float hit_t;
void main() { hit_t = -1.0; }
