/* Video frames end to end on lavapipe (protocol/stream.md, the video message; issue 26): a
 * version-2 viewer that asks for VP9 gets frames whose header says VP9, the first a key frame,
 * every one decodable by libvpx in order (no inter frame missing), and the still after the
 * camera stops as JPEG; a JPEG-only viewer beside it keeps getting JPEG; a resize gives a key
 * frame first; an unknown codec or an absurd bitrate is answered with the error message and the
 * viewer keeps JPEG. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "serve_util.h"
#include "test_util.h"
#include "video_decode.h"

static const char *const args[] = {
    "--no-animate", "--width", "64",      "--height",        "48", "--gi", "off",
    "--max-fps",    "60",      "--scene", "builtin:cornell", NULL};

typedef struct counts {
    unsigned jpeg, video, keys, stills, decoded, bad_decode, first_video_key, first_sized_key;
    unsigned width_seen; /* width of the frames the counts after a resize look for */
    bool saw_video, saw_sized_video;
} counts;

/* Receives v's frames for ms (acknowledging them); decodes the VP9 ones in order with dec. */
static void drain(pc_ws *ws, int ms, video_decoder *dec, counts *c)
{
    double end = pc_now_ms() + ms;
    for (;;) {
        int left = (int)(end - pc_now_ms());
        if (left <= 0) break;
        uint8_t *data;
        size_t len;
        int op = pc_ws_recv(ws, left, &data, &len);
        if (op <= 0) break;
        if (op != 2) continue; /* text */
        proto_frame_header h;
        const uint8_t *payload;
        if (proto_frame_header_unpack(data, len, &h, &payload) != PROTO_OK) {
            CHECK(!"a frame header that unpacks");
            continue;
        }
        bool key = (h.flags & PROTO_STREAM_FLAG_KEY) != 0;
        if (h.format == PROTO_FORMAT_JPEG) {
            c->jpeg++;
            c->stills += (h.flags & PROTO_STREAM_FLAG_STILL) != 0;
            CHECKF(h.quality > 0 && payload[0] == 0xff && payload[1] == 0xd8 && !key,
                   "a JPEG frame (quality %u)", h.quality);
        } else {
            CHECKF(h.format == PROTO_FORMAT_VP9 && h.quality == 0, "format %u", h.format);
            c->video++;
            c->keys += key;
            if (!c->saw_video) c->first_video_key = key;
            c->saw_video = true;
            if (c->width_seen && h.width == c->width_seen && !c->saw_sized_video) {
                c->first_sized_key = key;
                c->saw_sized_video = true;
            }
            if (dec) {
                video_picture pic;
                char err[256];
                if (video_decoder_decode(dec, payload, h.jpeg_size, &pic, err, sizeof err) &&
                    pic.width == h.width && pic.height == h.height && pic.key == key)
                    c->decoded++;
                else {
                    c->bad_decode++;
                    printf("frame %llu (%ux%u, key %d) did not decode: %s\n",
                           (unsigned long long)h.frame_id, h.width, h.height, key, err);
                }
            }
        }
        char ack[96];
        snprintf(ack, sizeof ack, "{\"type\":\"ack\",\"frame\":%llu}",
                 (unsigned long long)h.frame_id);
        pc_ws_send_text(ws, ack);
    }
}

/* Moves both viewers' cameras every 15 ms for ms, draining both; then the stills. */
static void move(pc_ws *a, video_decoder *dec, counts *ca, pc_ws *j, video_decoder *jdec,
                 counts *cj, int ms, int *seq)
{
    double end = pc_now_ms() + ms;
    char msg[160];
    for (int i = 0; pc_now_ms() < end; i++) {
        ++*seq;
        pc_camera_msg(msg, sizeof msg, *seq, -1.0 + 0.01 * (i % 200), 1.5, 3.5, 0, 0.5, 0);
        pc_ws_send_text(a, msg);
        pc_ws_send_text(j, msg);
        drain(a, 8, dec, ca);
        drain(j, 7, jdec, cj);
    }
    drain(a, 800, dec, ca);
    drain(j, 300, jdec, cj);
}

/* Sends a video request that must be refused: an error message comes back, frames stay JPEG. */
static void refused(pc_ws *ws, const char *json)
{
    CHECK(pc_ws_send_text(ws, json) == 0);
    cJSON *e = pc_stream_next_text(ws, 3000, "error");
    CHECKF(e != NULL, "an error message for %s", json);
    cJSON_Delete(e);
}

int main(void)
{
    pc_daemon d = {0};
    if (!pc_daemon_start(&d, args)) {
        CHECK(!"daemon started");
        return test_finish();
    }
    pc_ws a, j;
    uint32_t av, jv;
    CHECK(pc_stream_open_v2(&d, &a, &av));
    CHECK(pc_stream_open_v2(&d, &j, &jv));
    counts ca = {0}, cj = {0};
    drain(&a, 1500, NULL, &ca);
    drain(&j, 300, NULL, &cj);
    int seq = 0;

    /* bad requests: the error, the connection stays, frames stay JPEG */
    refused(&a, "{\"type\":\"video\",\"codec\":\"h264\",\"max_kbps\":null}");
    refused(&a, "{\"type\":\"video\",\"codec\":\"av1\",\"max_kbps\":null}");
    refused(&a, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":0}");
    refused(&a, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":1000000000}");
    memset(&ca, 0, sizeof ca);
    move(&a, NULL, &ca, &j, NULL, &cj, 800, &seq);
    printf("after bad requests: %u JPEG, %u video frames\n", ca.jpeg, ca.video);
    CHECKF(ca.jpeg >= 3 && ca.video == 0, "JPEG kept: %u JPEG, %u video", ca.jpeg, ca.video);

    /* VP9 */
    video_decoder *dec = NULL;
    char err[256];
    CHECKF(video_decoder_open(&dec, SRV_VIDEO_VP9, err, sizeof err), "decoder: %s", err);
    CHECK(pc_ws_send_text(&a, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":2000}") == 0);
    memset(&ca, 0, sizeof ca);
    memset(&cj, 0, sizeof cj);
    move(&a, dec, &ca, &j, NULL, &cj, 2000, &seq);
    printf("video viewer: %u VP9 (%u key, %u decoded, %u not), %u JPEG (%u stills); JPEG "
           "viewer: %u JPEG, %u video\n",
           ca.video, ca.keys, ca.decoded, ca.bad_decode, ca.jpeg, ca.stills, cj.jpeg, cj.video);
    CHECKF(ca.video >= 5, "VP9 frames: %u", ca.video);
    CHECK(ca.first_video_key);
    CHECKF(ca.keys == 1, "one key frame (join) while the size stays: %u", ca.keys);
    CHECKF(ca.decoded == ca.video && ca.bad_decode == 0, "all decode: %u of %u", ca.decoded,
           ca.video);
    CHECKF(ca.stills >= 1, "the still after the camera stops is JPEG: %u", ca.stills);
    CHECKF(cj.jpeg >= 5 && cj.video == 0, "JPEG viewer: %u JPEG, %u video", cj.jpeg, cj.video);

    /* reported: /v1/stats lists the video viewer as vp9 with a target and an encode time, the
     * other as jpeg; /metrics has the per-viewer series (the numbers are those of the last
     * second's tick: move again so that it sees frames) */
    move(&a, dec, &ca, &j, NULL, &cj, 1200, &seq);
    cJSON *stats = pc_api_get_json(&d, "/v1/stats");
    /* the video viewer's view is watched by it alone: its moving frames were made without JPEG */
    const cJSON *enc = cJSON_GetObjectItemCaseSensitive(stats, "encoder");
    CHECKF(pc_json_number(enc, "frames_video_only") >= 5, "frames without JPEG: %g",
           pc_json_number(enc, "frames_video_only"));
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(stats, "stream");
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(st, "viewers_detail");
    CHECK(cJSON_IsArray(list) && cJSON_GetArraySize(list) == 2);
    CHECK(pc_json_number(st, "video_viewers") == 1);
    const cJSON *it;
    unsigned vp9 = 0, jpeg = 0;
    cJSON_ArrayForEach(it, list)
    {
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(it, "format");
        double view = pc_json_number(it, "view");
        if (cJSON_IsString(f) && strcmp(f->valuestring, "vp9") == 0) {
            vp9++;
            CHECKF(view == av && pc_json_number(it, "target_kbps") >= 50 &&
                       pc_json_number(it, "target_kbps") <= 2000 &&
                       pc_json_number(it, "encode_ms") > 0,
                   "vp9 viewer: view %g, target %g kbit/s, encode %g ms", view,
                   pc_json_number(it, "target_kbps"), pc_json_number(it, "encode_ms"));
        } else if (cJSON_IsString(f) && strcmp(f->valuestring, "jpeg") == 0) {
            jpeg++;
            CHECK(view == jv && pc_json_number(it, "target_kbps") == 0);
        }
    }
    CHECKF(vp9 == 1 && jpeg == 1, "formats listed: %u vp9, %u jpeg", vp9, jpeg);
    cJSON_Delete(stats);
    pc_http_response m = {0};
    CHECK(pc_api(&d, "GET", "/metrics", NULL, true, &m) == 200 && m.body &&
          strstr(m.body, "probecast_viewer_encode_seconds{viewer=") &&
          strstr(m.body, "format=\"vp9\"") && strstr(m.body, "probecast_stream_video_viewers 1"));
    pc_http_response_free(&m);

    /* a resize: the first frame of the new size is a key frame, and decodes */
    CHECK(pc_ws_send_text(&a, "{\"type\":\"resize\",\"width\":80,\"height\":60}") == 0);
    memset(&ca, 0, sizeof ca);
    ca.width_seen = 80;
    move(&a, dec, &ca, &j, NULL, &cj, 1500, &seq);
    printf("after resize: %u VP9 (%u key, %u decoded), first of the new size key: %d\n", ca.video,
           ca.keys, ca.decoded, ca.first_sized_key);
    CHECK(ca.saw_sized_video && ca.first_sized_key);
    CHECKF(ca.decoded == ca.video && ca.bad_decode == 0, "all decode after resize: %u of %u",
           ca.decoded, ca.video);

    /* a new follower on video: its first VP9 frame of A's view is a key frame, and all decode */
    pc_ws fw;
    uint32_t fv;
    CHECK(pc_stream_open_v2(&d, &fw, &fv));
    counts cf = {0};
    drain(&fw, 500, NULL, &cf);
    video_decoder *fdec = NULL;
    CHECK(video_decoder_open(&fdec, SRV_VIDEO_VP9, err, sizeof err));
    CHECK(pc_ws_send_text(&fw, "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":null}") == 0);
    char follow[64];
    snprintf(follow, sizeof follow, "{\"type\":\"follow\",\"view\":%u}", av);
    CHECK(pc_ws_send_text(&fw, follow) == 0);
    cJSON *following = pc_stream_next_text(&fw, 3000, "following");
    CHECK(following != NULL);
    cJSON_Delete(following);
    memset(&cf, 0, sizeof cf);
    move(&a, dec, &ca, &fw, fdec, &cf, 1500, &seq);
    printf("follower: %u VP9 (%u key, %u decoded), %u JPEG\n", cf.video, cf.keys, cf.decoded,
           cf.jpeg);
    CHECKF(cf.video >= 3 && cf.first_video_key, "follower: %u VP9, first key %u", cf.video,
           cf.first_video_key);
    CHECKF(cf.decoded == cf.video && cf.bad_decode == 0, "follower decodes: %u of %u", cf.decoded,
           cf.video);
    video_decoder_close(fdec);
    pc_ws_close(&fw);

    /* codec null: back to JPEG */
    CHECK(pc_ws_send_text(&a, "{\"type\":\"video\",\"codec\":null,\"max_kbps\":null}") == 0);
    drain(&a, 300, NULL, &ca);
    memset(&ca, 0, sizeof ca);
    move(&a, NULL, &ca, &j, NULL, &cj, 800, &seq);
    CHECKF(ca.jpeg >= 3 && ca.video == 0, "JPEG again: %u JPEG, %u video", ca.jpeg, ca.video);

    video_decoder_close(dec);
    pc_ws_close(&a);
    pc_ws_close(&j);
    CHECK(pc_daemon_stop(&d) == 0);
    return test_finish();
}
