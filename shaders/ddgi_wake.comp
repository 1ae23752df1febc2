#version 460
/* DDGI wake events: one thread per probe. A probe inside one of this update's wake boxes
 * (GPU frame; the box is grown by one probe spacing here) wakes: sleeping becomes awake, and
 * its age drops to the event's (so its hysteresis starts low again) and its hold budget starts
 * over (ddgi_blend.glsl); an off probe is re-checked in this update. Runs before
 * ddgi_select.comp.
 * push: globals. */
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ddgi.glsl"

layout(local_size_x = PC_WG_1D) in;

void main()
{
    pc_globals g = load_globals();
    pc_ddgi_volume vol = g.ddgi;
    uint probe = gl_GlobalInvocationID.x;
    if (probe >= ddgi_probe_count(vol)) return;
    uint state = ddgi_probe_state(vol, probe);
    vec3 p = ddgi_probe_position(vol, probe);
    float age = -1.0;
    for (uint i = 0u; i < vol.control.z; i++) {
        pc_ddgi_wake box = DdgiWakeRef(vol.wake).v[i];
        if (all(greaterThanEqual(p, box.lo.xyz - vol.spacing.xyz)) &&
            all(lessThanEqual(p, box.hi.xyz + vol.spacing.xyz)))
            age = age < 0.0 ? box.lo.w : min(age, box.lo.w);
    }
    if (age < 0.0) return;
    DdgiStatsRef stats = DdgiStatsRef(vol.stats);
    vec4 st = stats.v[probe];
    if (state == PC_DDGI_PROBE_OFF) {
        st.w = 1.0;
    } else {
        if (state == PC_DDGI_PROBE_SLEEPING)
            DdgiProbeRef(vol.probes).v[probe].w = float(PC_DDGI_PROBE_AWAKE);
        st.x = min(st.x, age);
        st.y = 0.0; /* a new hold budget */
    }
    stats.v[probe] = st;
}
