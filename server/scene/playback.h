/* playback.h: the clip clock of the scene's glTF node animations (rd_scene.animations) — playing
 * or paused, and the clip time in seconds, looping over the longest animation
 * (rd_scene_animation_duration). Plain CPU code: it knows no scene; the caller poses the scene at
 * time_s (renderer/scene/animation_clip.h).
 *
 * The render thread owns a clock and moves it from wall time (monotonic milliseconds, clock.h).
 * Time passes only while the clock runs: playing, something to play (duration > 0) and someone
 * watching (like the demo light of animation.h), so a viewer who comes back finds the clip where
 * it was left. A copy of the clock is what the snapshot publishes: readers compute the current
 * time from it (srv_playback_time_at) without a publication per frame.
 */
#ifndef SRV_PLAYBACK_H
#define SRV_PLAYBACK_H

#include <stdbool.h>
#include <stdint.h>

#include <cjson/cJSON.h>

typedef struct srv_playback {
    uint32_t count;    /* animations in the scene */
    double duration_s; /* loop length; 0: nothing to play, the time stays 0 */
    bool playing;      /* as the API last set it (true after loading a scene with animations) */
    bool watched;      /* someone watches (told by the render loop) */
    double time_s;     /* clip time in [0, duration_s) at clock_ms (0 when duration_s is 0) */
    double clock_ms;   /* the wall time that time_s belongs to */
} srv_playback;

/* t wrapped into [0, duration_s); 0 when duration_s is not > 0 or t is not finite. */
double srv_playback_wrap(double t, double duration_s);

/* A new scene: count animations looping over duration_s, at time 0, playing when count > 0.
 * The watched flag is kept. */
void srv_playback_load(srv_playback *p, uint32_t count, double duration_s, double now_ms);
/* Time passes: playing, something to play and someone watching. */
bool srv_playback_running(const srv_playback *p);
/* The clip time at now_ms (time_s, plus the wall time since clock_ms while running, wrapped;
 * never less than time_s's place when now_ms is earlier than clock_ms). */
double srv_playback_time_at(const srv_playback *p, double now_ms);
/* Brings time_s to now_ms; true when it changed (the scene needs a new pose). */
bool srv_playback_advance(srv_playback *p, double now_ms);
/* Play or pause at now_ms (the time reached so far is kept). */
void srv_playback_set_playing(srv_playback *p, bool playing, double now_ms);
/* Someone watches, or nobody does any more; true when that starts or stops the clock. Cheap
 * when nothing changes (time_s is then left as it is, for srv_playback_advance). */
bool srv_playback_set_watched(srv_playback *p, bool watched, double now_ms);
/* Jumps to t seconds (finite; wrapped into the loop) at now_ms. */
void srv_playback_seek(srv_playback *p, double t, double now_ms);

/* The GET /v1/animation document of the clock at now_ms (count, duration, playing, time). */
cJSON *srv_json_playback(const srv_playback *p, double now_ms);

#endif
