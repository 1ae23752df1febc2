/* playback.c: the clip clock of the scene's animations (see playback.h). */
#include "server/scene/playback.h"

#include "server/api/api_json.h"

#include <math.h>

double srv_playback_wrap(double t, double duration_s)
{
    if (!(duration_s > 0) || !isfinite(duration_s) || !isfinite(t)) return 0;
    double r = fmod(t, duration_s);
    if (r < 0) r += duration_s;
    return r < duration_s ? r : 0; /* -tiny + duration rounds up to duration */
}

void srv_playback_load(srv_playback *p, uint32_t count, double duration_s, double now_ms)
{
    bool watched = p->watched;
    *p = (srv_playback){
        .count = count,
        .duration_s = duration_s > 0 && isfinite(duration_s) ? duration_s : 0,
        .playing = count > 0,
        .watched = watched,
        .clock_ms = now_ms,
    };
}

bool srv_playback_running(const srv_playback *p)
{
    return p->playing && p->watched && p->duration_s > 0;
}

double srv_playback_time_at(const srv_playback *p, double now_ms)
{
    if (!srv_playback_running(p)) return p->time_s;
    double dt = now_ms > p->clock_ms ? (now_ms - p->clock_ms) / 1000.0 : 0;
    return srv_playback_wrap(p->time_s + dt, p->duration_s);
}

bool srv_playback_advance(srv_playback *p, double now_ms)
{
    double t = srv_playback_time_at(p, now_ms);
    bool changed = t != p->time_s;
    p->time_s = t;
    if (now_ms > p->clock_ms || !srv_playback_running(p)) p->clock_ms = now_ms;
    return changed;
}

void srv_playback_set_playing(srv_playback *p, bool playing, double now_ms)
{
    srv_playback_advance(p, now_ms);
    p->playing = playing;
}

bool srv_playback_set_watched(srv_playback *p, bool watched, double now_ms)
{
    if (watched == p->watched) return false; /* the time is left for srv_playback_advance */
    bool was = srv_playback_running(p);
    srv_playback_advance(p, now_ms);
    p->watched = watched;
    return was != srv_playback_running(p);
}

void srv_playback_seek(srv_playback *p, double t, double now_ms)
{
    srv_playback_advance(p, now_ms);
    p->time_s = srv_playback_wrap(t, p->duration_s);
}

cJSON *srv_json_playback(const srv_playback *p, double now_ms)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "count", p->count);
    cJSON_AddNumberToObject(j, "duration", srv_json_float((float)p->duration_s));
    cJSON_AddBoolToObject(j, "playing", p->playing);
    /* microseconds are enough, and print short */
    double t = round(srv_playback_time_at(p, now_ms) * 1e6) / 1e6;
    cJSON_AddNumberToObject(j, "time", t < p->duration_s ? t : 0);
    return j;
}
