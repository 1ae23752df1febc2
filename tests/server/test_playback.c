/* The clip clock of the scene's animations without a GPU: looping, play and pause, seeking,
 * watching, and the time readers compute from a published copy. Also the PATCH /v1/animation
 * body parser and the document. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "server/api/api_json.h"
#include "server/scene/playback.h"
#include "test_util.h"

static int near(double a, double b)
{
    return fabs(a - b) < 1e-9;
}

static void test_wrap(void)
{
    CHECK(near(srv_playback_wrap(0.5, 2), 0.5));
    CHECK(near(srv_playback_wrap(2, 2), 0));
    CHECK(near(srv_playback_wrap(5.25, 2), 1.25));
    CHECK(near(srv_playback_wrap(-0.5, 2), 1.5));
    CHECK(srv_playback_wrap(-1e-20, 2) < 2); /* rounds to 2: wrapped to 0 */
    CHECK(srv_playback_wrap(1e300, 3) >= 0 && srv_playback_wrap(1e300, 3) < 3);
    CHECK(srv_playback_wrap(3, 0) == 0);
    CHECK(srv_playback_wrap(NAN, 2) == 0 && srv_playback_wrap(INFINITY, 2) == 0);
    CHECK(srv_playback_wrap(1, NAN) == 0 && srv_playback_wrap(1, -2) == 0);
}

static void test_clock(void)
{
    srv_playback p = {0};
    srv_playback_load(&p, 2, 4.0, 1000);
    CHECKF(p.playing && p.count == 2 && p.time_s == 0, "a scene with animations starts playing");
    /* nobody watches: the clock stands */
    CHECK(!srv_playback_running(&p));
    CHECK(!srv_playback_advance(&p, 3000) && p.time_s == 0);
    CHECK(srv_playback_time_at(&p, 9000) == 0);
    /* a viewer comes: it runs from then on */
    CHECK(srv_playback_set_watched(&p, true, 3000));
    CHECK(!srv_playback_set_watched(&p, true, 3100)); /* no change */
    CHECKF(p.time_s == 0 && srv_playback_running(&p), "the time is left to advance");
    CHECK(near(srv_playback_time_at(&p, 4500), 1.5));
    CHECK(srv_playback_advance(&p, 4500) && near(p.time_s, 1.5));
    CHECK(near(srv_playback_time_at(&p, 4400), 1.5)); /* never backwards */
    /* a published copy extrapolates like the clock itself advances */
    srv_playback copy = p;
    CHECK(srv_playback_advance(&p, 5000) && srv_playback_advance(&p, 7250));
    CHECK(near(p.time_s, srv_playback_time_at(&copy, 7250)) && near(p.time_s, 4.25 - 4.0));
    /* pause: the time stays */
    srv_playback_set_playing(&p, false, 8000);
    CHECK(!p.playing && near(p.time_s, 1.0) && !srv_playback_running(&p));
    CHECK(!srv_playback_advance(&p, 20000) && near(srv_playback_time_at(&p, 30000), 1.0));
    /* seek while paused */
    srv_playback_seek(&p, 9.5, 21000);
    CHECK(near(p.time_s, 1.5) && near(srv_playback_time_at(&p, 50000), 1.5));
    /* play again: from there */
    srv_playback_set_playing(&p, true, 22000);
    CHECK(near(srv_playback_time_at(&p, 22500), 2.0));
    /* seek while playing: from the new time on */
    srv_playback_seek(&p, 3.0, 23000);
    CHECK(near(srv_playback_time_at(&p, 24500), 0.5));
    /* the viewers leave: the clock stops where it is, and resumes there */
    CHECK(srv_playback_set_watched(&p, false, 24000));
    CHECK(near(p.time_s, 4.0 - 4.0) && near(srv_playback_time_at(&p, 60000), 0.0));
    CHECK(srv_playback_set_watched(&p, true, 70000));
    CHECK(near(srv_playback_time_at(&p, 70250), 0.25));
    /* a new scene: back to 0, still watched */
    srv_playback_load(&p, 1, 2.0, 80000);
    CHECK(p.watched && p.playing && p.time_s == 0 && srv_playback_running(&p));
}

static void test_nothing_to_play(void)
{
    srv_playback p = {0};
    srv_playback_load(&p, 0, 0, 0);
    CHECK(!p.playing && p.duration_s == 0);
    srv_playback_set_watched(&p, true, 0);
    srv_playback_set_playing(&p, true, 10);
    CHECKF(p.playing && !srv_playback_running(&p), "playing is kept, but nothing runs");
    srv_playback_seek(&p, 5, 20);
    CHECK(p.time_s == 0 && !srv_playback_advance(&p, 5000) && srv_playback_time_at(&p, 9000) == 0);
    /* animations of duration 0 (one key each): posed at 0, the clock never moves */
    srv_playback_load(&p, 3, 0, 0);
    CHECK(p.playing && !srv_playback_running(&p) && srv_playback_time_at(&p, 1000) == 0);
}

static bool parse(const char *text, srv_playback_patch *out, srv_api_error *e)
{
    cJSON *j = srv_json_parse_object(text, strlen(text), e);
    if (!j) return false;
    bool ok = srv_json_playback_patch(j, out, e);
    cJSON_Delete(j);
    return ok;
}

static void test_json(void)
{
    srv_playback_patch p;
    srv_api_error e;
    CHECK(parse("{\"playing\":false}", &p, &e) && p.has == SRV_PLAY_PLAYING && !p.playing);
    CHECK(parse("{\"time\":1.25,\"playing\":true}", &p, &e) &&
          p.has == (SRV_PLAY_PLAYING | SRV_PLAY_TIME) && p.playing && p.time_s == 1.25);
    CHECK(parse("{\"time\":0}", &p, &e) && p.has == SRV_PLAY_TIME && p.time_s == 0);
    const char *bad[] = {"{}",
                         "{\"time\":-1}",
                         "{\"time\":\"1\"}",
                         "{\"time\":null}",
                         "{\"time\":1e999}",
                         "{\"playing\":1}",
                         "{\"playing\":\"true\"}",
                         "{\"playing\":true,\"playing\":false}",
                         "{\"speed\":2}",
                         NULL};
    for (int i = 0; bad[i]; i++) {
        bool ok = parse(bad[i], &p, &e);
        CHECKF(!ok && e.status == 400, "%s refused (%s)", bad[i], e.message);
    }
    /* the document */
    srv_playback pb = {0};
    srv_playback_load(&pb, 1, 2.0, 0);
    srv_playback_set_watched(&pb, true, 0);
    cJSON *j = srv_json_playback(&pb, 500);
    CHECK(cJSON_GetObjectItem(j, "count")->valuedouble == 1);
    CHECK(cJSON_GetObjectItem(j, "duration")->valuedouble == 2.0);
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(j, "playing")));
    CHECK(near(cJSON_GetObjectItem(j, "time")->valuedouble, 0.5));
    CHECK(cJSON_GetArraySize(j) == 4);
    cJSON_Delete(j);
    j = srv_json_playback(&pb, 1999.9999999); /* rounds to the loop's end: shown as 0 */
    CHECK(cJSON_GetObjectItem(j, "time")->valuedouble == 0);
    cJSON_Delete(j);
}

int main(void)
{
    test_wrap();
    test_clock();
    test_nothing_to_play();
    test_json();
    return test_finish();
}
