/* stats_report.c: the numbers of /v1/stats and /metrics. */
#include "server/http/stats_report.h"

#include "protocol/stream.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/api/api_json.h"

cJSON *srv_stats_json(const srv_stats_snapshot *s)
{
    const srv_render_stats *r = &s->render;
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "device", r->device);
    cJSON_AddBoolToObject(j, "device_lost", r->device_lost);
    cJSON_AddStringToObject(j, "last_error", r->last_error);
    cJSON_AddNumberToObject(j, "uptime_s", (double)(uint64_t)(s->uptime_s * 1000) / 1000);
    cJSON_AddBoolToObject(j, "rendering", r->rendering);
    cJSON_AddNumberToObject(j, "fps", r->fps);
    cJSON_AddNumberToObject(j, "frames_rendered", (double)r->frames_rendered);
    cJSON_AddNumberToObject(j, "stills_reencoded", (double)r->stills_reencoded);
    cJSON_AddNumberToObject(j, "commands_applied", (double)r->commands_applied);
    cJSON *res = cJSON_AddArrayToObject(j, "resolution");
    cJSON_AddItemToArray(res, cJSON_CreateNumber(r->width));
    cJSON_AddItemToArray(res, cJSON_CreateNumber(r->height));
    cJSON_AddNumberToObject(j, "frame_ms", r->frame_ms_last);
    cJSON *gpu = cJSON_AddObjectToObject(j, "gpu_ms");
    for (unsigned i = 0; i < r->view_passes.count; i++)
        cJSON_AddNumberToObject(gpu, r->view_passes.name[i], r->view_passes.ms[i]);
    cJSON_AddNumberToObject(j, "gpu_ms_total", r->view_passes.total_ms);
    cJSON_AddNumberToObject(j, "rays_last_frame", (double)r->view_passes.rays);
    cJSON_AddNumberToObject(j, "rays_per_second", r->rays_per_second);
    cJSON *enc = cJSON_AddObjectToObject(j, "encoder");
    cJSON_AddNumberToObject(enc, "encode_ms", s->encoder.encode_ms_avg);
    cJSON_AddNumberToObject(enc, "encode_ms_last", s->encoder.encode_ms_last);
    cJSON_AddNumberToObject(enc, "jpegs_encoded", (double)s->encoder.jpegs_encoded);
    cJSON_AddNumberToObject(enc, "jpegs_striped", (double)s->encoder.jpegs_striped);
    cJSON_AddStringToObject(enc, "path", r->jpeg_gpu ? "gpu" : "cpu");
    cJSON_AddNumberToObject(enc, "jpegs_from_gpu", (double)s->encoder.jpegs_from_gpu);
    cJSON_AddNumberToObject(enc, "frames_published", (double)s->encoder.frames_published);
    cJSON_AddNumberToObject(enc, "frames_dropped", (double)s->encoder.frames_dropped);
    cJSON_AddNumberToObject(enc, "frames_video_only", (double)s->encoder.frames_video_only);
    cJSON *w = cJSON_AddObjectToObject(j, "world");
    cJSON_AddNumberToObject(w, "ticks", (double)r->world_ticks);
    cJSON_AddNumberToObject(w, "probe_updates", (double)r->world_updates_total);
    cJSON_AddNumberToObject(w, "probe_updates_per_second", r->world_updates_per_second);
    cJSON *wgpu = cJSON_AddObjectToObject(w, "gpu_ms");
    for (unsigned i = 0; i < r->world_passes.count; i++)
        cJSON_AddNumberToObject(wgpu, r->world_passes.name[i], r->world_passes.ms[i]);
    cJSON_AddNumberToObject(w, "gpu_ms_total", r->world_passes.total_ms);
    cJSON *vw = cJSON_AddObjectToObject(j, "views");
    cJSON_AddNumberToObject(vw, "count", r->views);
    cJSON_AddNumberToObject(vw, "watched", r->views_watched);
    cJSON *p = cJSON_AddObjectToObject(j, "probes");
    cJSON_AddStringToObject(p, "mode", srv_gi_mode_name(r->gi_mode));
    cJSON *c = cJSON_AddArrayToObject(p, "counts");
    for (int i = 0; i < 3; i++)
        cJSON_AddItemToArray(c, cJSON_CreateNumber(r->probe_counts[i]));
    cJSON_AddNumberToObject(p, "total", r->probes);
    cJSON_AddNumberToObject(p, "rays_per_probe", r->rays_per_probe);
    cJSON_AddNumberToObject(p, "updates_since_change", r->gi_updates);
    cJSON *states = cJSON_AddObjectToObject(p, "states");
    cJSON_AddNumberToObject(states, "awake", r->probes_awake);
    cJSON_AddNumberToObject(states, "sleeping", r->probes_sleeping);
    cJSON_AddNumberToObject(states, "off", r->probes_off);
    cJSON_AddBoolToObject(p, "converged", r->gi_converged);
    /* convergence: the share of the probes that light the scene (not off) that have settled */
    unsigned lit = r->probes_awake + r->probes_sleeping;
    cJSON_AddNumberToObject(p, "convergence", lit ? (double)r->probes_sleeping / lit : 1.0);
    cJSON_AddNumberToObject(p, "drift_per_update", r->gi_drift);
    cJSON_AddNumberToObject(p, "updates_per_second", r->world_updates_per_second);
    cJSON *sm = cJSON_AddObjectToObject(p, "shadow_maps");
    cJSON_AddNumberToObject(sm, "lights", r->shadow_map_lights);
    cJSON_AddNumberToObject(sm, "builds", (double)r->shadow_map_builds);
    cJSON_AddNumberToObject(sm, "bytes", (double)r->shadow_map_bytes);
    if (r->pt_target) {
        cJSON *pt = cJSON_AddObjectToObject(j, "pathtrace");
        cJSON_AddNumberToObject(pt, "samples", r->pt_samples);
        cJSON_AddNumberToObject(pt, "target", r->pt_target);
        cJSON *pv = cJSON_AddArrayToObject(pt, "views");
        for (unsigned i = 0; i < r->pt_view_count; i++) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "view", r->pt_views[i].view);
            cJSON_AddNumberToObject(o, "samples", r->pt_views[i].samples);
            cJSON_AddItemToArray(pv, o);
        }
    } else {
        cJSON_AddNullToObject(j, "pathtrace");
    }
    cJSON *st = cJSON_AddObjectToObject(j, "stream");
    cJSON_AddNumberToObject(st, "viewers", s->stream.viewers);
    cJSON_AddNumberToObject(st, "bandwidth_bps", s->stream.bandwidth_bps);
    cJSON_AddNumberToObject(st, "bytes_sent", (double)s->stream.bytes_sent);
    cJSON_AddNumberToObject(st, "frames_sent", (double)s->stream.frames_sent);
    cJSON_AddNumberToObject(st, "frames_skipped", (double)s->stream.frames_skipped);
    cJSON_AddNumberToObject(st, "messages_received", (double)s->stream.messages_received);
    cJSON_AddNumberToObject(st, "events_sent", (double)s->stream.events_sent);
    cJSON_AddNumberToObject(st, "lag_ms_max", s->stream.lag_ms_max);
    const srv_latency_summary *lat = &s->stream.latency;
    cJSON *lj = cJSON_AddObjectToObject(st, "input_to_frame");
    cJSON_AddNumberToObject(lj, "samples", (double)lat->samples);
    cJSON_AddNumberToObject(lj, "window", lat->count);
    const char *kinds[3] = {"p50", "p95", "mean"};
    const double *vals[3] = {lat->p50, lat->p95, lat->mean};
    for (int k = 0; k < 3; k++) {
        cJSON *o = cJSON_AddObjectToObject(lj, kinds[k]);
        for (int i = 0; i < SRV_LAT_STAGES; i++)
            cJSON_AddNumberToObject(o, srv_latency_stage_names[i], round(vals[k][i] * 1000) / 1000);
    }
    cJSON_AddNumberToObject(st, "connections_rejected", (double)s->stream.connections_rejected);
    cJSON_AddNumberToObject(st, "connections_closed_for_abuse",
                            (double)s->stream.connections_closed_for_abuse);
    cJSON_AddNumberToObject(st, "inputs_dropped", (double)s->stream.inputs_dropped);
    cJSON_AddNumberToObject(st, "video_viewers", s->stream.video_viewers);
    cJSON *pv = cJSON_AddArrayToObject(st, "viewers_detail");
    for (unsigned i = 0; i < s->stream.viewer_count; i++) {
        const srv_ws_viewer_stats *v = &s->stream.per_viewer[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "viewer", v->viewer);
        cJSON_AddNumberToObject(o, "view", v->view);
        cJSON_AddStringToObject(o, "format", proto_format_name(v->format));
        cJSON_AddNumberToObject(o, "target_kbps", v->target_kbps);
        cJSON_AddNumberToObject(o, "sent_kbps", round(v->sent_kbps * 10) / 10);
        cJSON_AddNumberToObject(o, "encode_ms", round(v->encode_ms * 1000) / 1000);
        cJSON_AddItemToArray(pv, o);
    }
    cJSON *h = cJSON_AddObjectToObject(j, "http");
    cJSON_AddNumberToObject(h, "requests", (double)s->http.requests);
    cJSON_AddNumberToObject(h, "status_2xx", (double)s->http.status_2xx);
    cJSON_AddNumberToObject(h, "status_4xx", (double)s->http.status_4xx);
    cJSON_AddNumberToObject(h, "status_5xx", (double)s->http.status_5xx);
    cJSON_AddNumberToObject(h, "uploads_accepted", (double)s->http.uploads_accepted);
    cJSON_AddNumberToObject(h, "uploads_rejected", (double)s->http.uploads_rejected);
    cJSON_AddNumberToObject(h, "connections_open", s->http.connections_open);
    cJSON_AddNumberToObject(h, "connections_refused", (double)s->http.connections_refused);
    cJSON_AddNumberToObject(h, "connections_per_ip", s->http.connections_per_ip);
    cJSON_AddNumberToObject(h, "idle_timeout_s", s->http.idle_timeout_s);
    cJSON *scene = cJSON_AddObjectToObject(j, "scene");
    cJSON_AddNumberToObject(scene, "generation", (double)r->scene_generation);
    cJSON_AddNumberToObject(scene, "triangles", (double)r->triangles);
    cJSON *df = cJSON_AddObjectToObject(scene, "deform");
    cJSON_AddNumberToObject(df, "deform_build_ms", round(r->deform_build_ms * 1000) / 1000);
    cJSON_AddNumberToObject(df, "deform_ms", round(r->deform_ms * 1000) / 1000);
    cJSON_AddNumberToObject(df, "refit_ms", round(r->refit_ms * 1000) / 1000);
    cJSON_AddNumberToObject(df, "refits", (double)r->deform_refits);
    cJSON_AddNumberToObject(df, "rebuilds", (double)r->deform_rebuilds);
    cJSON_AddNumberToObject(df, "gpu_rebuilds", (double)r->deform_gpu_rebuilds);
    cJSON *mem = cJSON_AddObjectToObject(j, "memory");
    cJSON_AddNumberToObject(mem, "rss_bytes", (double)s->memory.rss_bytes);
    cJSON_AddNumberToObject(mem, "peak_rss_bytes", (double)s->memory.peak_rss_bytes);
    cJSON_AddNumberToObject(mem, "heap_in_use_bytes", (double)s->memory.heap_in_use_bytes);
    cJSON_AddNumberToObject(mem, "heap_free_bytes", (double)s->memory.heap_free_bytes);
    cJSON_AddNumberToObject(mem, "heap_mmap_bytes", (double)s->memory.heap_mmap_bytes);
    return j;
}

typedef struct text {
    char *buf;
    size_t len, cap;
} text;

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void
put(text *t, const char *fmt, ...)
{
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(t->buf + t->len, t->cap - t->len, fmt, ap);
        va_end(ap);
        if (n >= 0 && (size_t)n < t->cap - t->len) {
            t->len += (size_t)n;
            return;
        }
        t->cap = t->cap * 2 + (size_t)(n > 0 ? n : 0) + 256;
        t->buf = realloc(t->buf, t->cap);
        if (!t->buf) abort();
    }
}

static void metric(text *t, const char *name, const char *type, const char *help, double v)
{
    put(t, "# HELP %s %s\n# TYPE %s %s\n%s %.17g\n", name, help, name, type, name, v);
}

char *srv_stats_prometheus(const srv_stats_snapshot *s)
{
    text t = {.cap = 4096};
    t.buf = malloc(t.cap);
    if (!t.buf) abort();
    t.buf[0] = 0;
    const srv_render_stats *r = &s->render;
    metric(&t, "probecast_up", "gauge", "1 while the GPU device works.", r->device_lost ? 0 : 1);
    metric(&t, "probecast_uptime_seconds", "gauge", "Seconds since the server started.",
           s->uptime_s);
    metric(&t, "probecast_resident_memory_bytes", "gauge", "Resident memory of the daemon.",
           (double)s->memory.rss_bytes);
    metric(&t, "probecast_heap_in_use_bytes", "gauge",
           "C heap allocated and not freed (0 where the allocator does not tell).",
           (double)s->memory.heap_in_use_bytes);
    metric(&t, "probecast_heap_free_bytes", "gauge",
           "C heap freed but kept by the allocator (fragmentation shows here).",
           (double)s->memory.heap_free_bytes);
    metric(&t, "probecast_rendering", "gauge", "1 while something changes and frames are rendered.",
           r->rendering);
    metric(&t, "probecast_fps", "gauge", "Frames rendered in the last second.", r->fps);
    metric(&t, "probecast_frames_rendered_total", "counter", "Frames rendered.",
           (double)r->frames_rendered);
    metric(&t, "probecast_frame_gpu_seconds", "gauge", "GPU time of the last frame.",
           r->view_passes.total_ms / 1000.0);
    put(&t, "# HELP probecast_pass_gpu_seconds GPU time of each pass of the last frame "
            "and of the last world update.\n"
            "# TYPE probecast_pass_gpu_seconds gauge\n");
    const srv_pass_times *sets[2] = {&r->view_passes, &r->world_passes};
    for (int k = 0; k < 2; k++)
        for (unsigned i = 0; i < sets[k]->count; i++) {
            char label[SRV_PASS_NAME_MAX];
            snprintf(label, sizeof label, "%s", sets[k]->name[i]);
            for (char *q = label; *q; q++)
                if (*q == '"' || *q == '\\' || *q == '\n') *q = '_';
            put(&t, "probecast_pass_gpu_seconds{pass=\"%s\"} %.17g\n", label,
                sets[k]->ms[i] / 1000.0);
        }
    put(&t, "# HELP probecast_input_to_frame_seconds Input-to-frame time per stage over the "
            "newest 256 inputs (median and 95th percentile).\n"
            "# TYPE probecast_input_to_frame_seconds gauge\n");
    const srv_latency_summary *lat = &s->stream.latency;
    for (int i = 0; i < SRV_LAT_STAGES; i++) {
        char stage[24];
        snprintf(stage, sizeof stage, "%s", srv_latency_stage_names[i]);
        char *ms = strstr(stage, "_ms");
        if (ms) *ms = 0;
        put(&t, "probecast_input_to_frame_seconds{stage=\"%s\",quantile=\"0.5\"} %.17g\n", stage,
            lat->p50[i] / 1000.0);
        put(&t, "probecast_input_to_frame_seconds{stage=\"%s\",quantile=\"0.95\"} %.17g\n", stage,
            lat->p95[i] / 1000.0);
    }
    metric(&t, "probecast_world_ticks_total", "counter", "Times the shared world advanced.",
           (double)r->world_ticks);
    metric(&t, "probecast_probe_updates_total", "counter", "DDGI probe updates run.",
           (double)r->world_updates_total);
    metric(&t, "probecast_deform_seconds", "gauge",
           "Wall time of the last pose's deforming-mesh work (GPU and CPU).",
           r->deform_build_ms / 1000.0);
    metric(&t, "probecast_deform_gpu_seconds", "gauge",
           "GPU time of the last GPU pose's posing and triangle records.", r->deform_ms / 1000.0);
    metric(&t, "probecast_refit_gpu_seconds", "gauge",
           "GPU time of the last GPU pose's BVH refits.", r->refit_ms / 1000.0);
    metric(&t, "probecast_deform_refits_total", "counter",
           "Mesh poses whose BVH was refitted on the GPU.", (double)r->deform_refits);
    metric(&t, "probecast_deform_rebuilds_total", "counter",
           "Mesh poses whose BVH was rebuilt on the CPU.", (double)r->deform_rebuilds);
    metric(&t, "probecast_deform_gpu_rebuilds_total", "counter",
           "Mesh poses whose BVH was rebuilt on the GPU (LBVH).", (double)r->deform_gpu_rebuilds);
    metric(&t, "probecast_views", "gauge", "Views (the default view and one per viewer).",
           r->views);
    metric(&t, "probecast_rays_per_second", "gauge",
           "Rays per second of GPU time in the last frame.", r->rays_per_second);
    metric(&t, "probecast_probes", "gauge", "DDGI probes.", r->probes);
    metric(&t, "probecast_probe_updates_since_change", "gauge",
           "Probe updates since the last change that woke probes.", r->gi_updates);
    metric(&t, "probecast_probes_awake", "gauge", "DDGI probes traced and blended every update.",
           r->probes_awake);
    metric(&t, "probecast_probes_sleeping", "gauge",
           "DDGI probes converged: sampled, neither traced nor blended.", r->probes_sleeping);
    metric(&t, "probecast_probes_off", "gauge", "DDGI probes inside geometry: not sampled.",
           r->probes_off);
    metric(&t, "probecast_jpeg_encode_seconds", "gauge", "Mean JPEG encoding time.",
           s->encoder.encode_ms_avg / 1000.0);
    metric(&t, "probecast_jpegs_encoded_total", "counter", "JPEG images encoded.",
           (double)s->encoder.jpegs_encoded);
    metric(&t, "probecast_frames_published_total", "counter", "Frames published to viewers.",
           (double)s->encoder.frames_published);
    metric(&t, "probecast_viewers", "gauge", "Connected viewers.", s->stream.viewers);
    metric(&t, "probecast_stream_bandwidth_bytes_per_second", "gauge",
           "Bytes per second sent to viewers over the last second.", s->stream.bandwidth_bps / 8.0);
    metric(&t, "probecast_stream_bytes_total", "counter", "Bytes sent to viewers.",
           (double)s->stream.bytes_sent);
    metric(&t, "probecast_stream_frames_sent_total", "counter", "Frames sent to viewers.",
           (double)s->stream.frames_sent);
    metric(&t, "probecast_stream_frames_skipped_total", "counter",
           "Frames viewers skipped (latest frame wins).", (double)s->stream.frames_skipped);
    metric(&t, "probecast_stream_lag_seconds_max", "gauge", "Largest smoothed viewer lag.",
           s->stream.lag_ms_max / 1000.0);
    metric(&t, "probecast_stream_inputs_dropped_total", "counter",
           "Viewer messages the render queue had no room for.", (double)s->stream.inputs_dropped);
    metric(&t, "probecast_stream_video_viewers", "gauge", "Viewers sent video (VP8 or VP9).",
           s->stream.video_viewers);
    put(&t, "# HELP probecast_viewer_bitrate_bits_per_second Payload bits per second sent to each "
            "viewer over the last second (target=\"0\") and its video encoder's target "
            "(target=\"1\"; 0 for JPEG).\n"
            "# TYPE probecast_viewer_bitrate_bits_per_second gauge\n");
    for (unsigned i = 0; i < s->stream.viewer_count; i++) {
        const srv_ws_viewer_stats *v = &s->stream.per_viewer[i];
        for (int target = 0; target < 2; target++)
            put(&t,
                "probecast_viewer_bitrate_bits_per_second{viewer=\"%u\",view=\"%u\","
                "format=\"%s\",target=\"%d\"} %.17g\n",
                v->viewer, v->view, proto_format_name(v->format), target,
                target ? v->target_kbps * 1000.0 : v->sent_kbps * 1000);
    }
    put(&t, "# HELP probecast_viewer_encode_seconds Smoothed video encode time of a frame per "
            "viewer (0 for JPEG viewers: the shared JPEG encoders make their frames).\n"
            "# TYPE probecast_viewer_encode_seconds gauge\n");
    for (unsigned i = 0; i < s->stream.viewer_count; i++) {
        const srv_ws_viewer_stats *v = &s->stream.per_viewer[i];
        put(&t,
            "probecast_viewer_encode_seconds{viewer=\"%u\",view=\"%u\",format=\"%s\"} "
            "%.17g\n",
            v->viewer, v->view, proto_format_name(v->format), v->encode_ms / 1000);
    }
    metric(&t, "probecast_http_connections", "gauge", "HTTP connections open (stream included).",
           s->http.connections_open);
    metric(&t, "probecast_http_connections_refused_total", "counter",
           "HTTP connections refused for their address's limit.",
           (double)s->http.connections_refused);
    put(&t,
        "# HELP probecast_http_responses_total HTTP responses by status class.\n"
        "# TYPE probecast_http_responses_total counter\n"
        "probecast_http_responses_total{class=\"2xx\"} %llu\n"
        "probecast_http_responses_total{class=\"4xx\"} %llu\n"
        "probecast_http_responses_total{class=\"5xx\"} %llu\n",
        (unsigned long long)s->http.status_2xx, (unsigned long long)s->http.status_4xx,
        (unsigned long long)s->http.status_5xx);
    return t.buf;
}
