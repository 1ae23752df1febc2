#version 460
/* DDGI update selection (2021 follow-up paper, probe states): one thread per probe. Counts the
 * probes per state and lists those this update works on — every awake probe, and off probes
 * whose re-check is due (every PC_DDGI_OFF_RECHECK updates, staggered, or after a wake event
 * reached them). Sleeping probes are not listed: no ray, shading or blending work at all. The
 * list's length lands in the indirect dispatch sizes of the passes that follow. It also marks,
 * for every probe, which segments to its +x, +y, +z neighbours geometry crosses (stats.z): the
 * cells where the irradiance query traces visibility rays (ddgi.glsl, PC_DDGI_VIS_*).
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
    /* which segments to the +x, +y, +z neighbours geometry crosses (stats.z, ddgi_probe_edges):
     * three short rays per probe and update, so that the cells that need visibility rays in
     * ddgi_irradiance follow moving geometry */
    ivec3 c = ddgi_probe_coord(vol, probe);
    vec3 pos = ddgi_probe_position(vol, probe);
    uint edges = 0u;
    bool wanted = vol.info.x == PC_GI_DDGI && uint(vol.spacing.w) != PC_DDGI_VIS_OFF;
    for (int k = 0; k < 3 && wanted; k++) {
        ivec3 nc = c;
        nc[k] += 1;
        if (nc[k] >= int(vol.counts[k])) continue;
        vec3 to = ddgi_probe_position(vol, ddgi_probe_index(vol, nc)) - pos;
        float dist = length(to);
        pc_hit h;
        if (dist > 0.0 && trace_ray(g.scene, pos, to / dist, 0.0, dist, PC_TRACE_ANY_HIT, h))
            edges |= 1u << uint(k);
    }
    DdgiStatsRef(vol.stats).v[probe].z = float(edges);
    DdgiControlRef ctrl = DdgiControlRef(vol.ctrl);
    uint state = ddgi_probe_state(vol, probe);
    bool listed;
    if (state == PC_DDGI_PROBE_SLEEPING) {
        atomicAdd(ctrl.before.y, 1u);
        listed = false;
    } else if ((state & PC_DDGI_PROBE_ACTIVE) != 0u) {
        atomicAdd(ctrl.before.x, 1u);
        listed = true;
    } else {
        atomicAdd(ctrl.before.z, 1u);
        DdgiStatsRef stats = DdgiStatsRef(vol.stats);
        /* w = 2 tells the blend that a wake event (geometry moved) listed it: if it comes back
         * on, it starts over; a periodic re-check that finds it on keeps its age */
        bool woken = stats.v[probe].w != 0.0;
        listed = woken || (probe + vol.info.y) % PC_DDGI_OFF_RECHECK == 0u;
        stats.v[probe].w = woken ? 2.0 : 0.0;
    }
    if (!listed) return;
    uint slot = atomicAdd(ctrl.trace_args.y, 1u);
    atomicAdd(ctrl.blend_args.x, 1u);
    atomicAdd(ctrl.border_args.y, 1u);
    atomicAdd(ctrl.before.w, 1u);
    DdgiListRef(vol.list).v[slot] = probe;
}
