/* Strict parsing of the stream's viewer messages (server/stream/viewer_msg.h; plain CPU code: no
 * daemon, no GPU). */
#include <string.h>

#include "server/stream/viewer_msg.h"
#include "protocol/stream.h"
#include "test_util.h"

static void test_viewer_messages(void)
{
    srv_viewer_msg m;
    srv_api_error e;
    const char *cam = "{\"type\":\"camera\",\"seq\":12,\"position\":[1,2,3],\"target\":[0,0,0]}";
    CHECK(srv_json_viewer_msg(cam, strlen(cam), &m, &e));
    CHECK(m.type == SRV_VIEWER_CAMERA && m.seq == 12 && (m.camera.has & SRV_CAM_TARGET));
    const char *rs = "{\"type\":\"resize\",\"width\":800,\"height\":600,\"dpr\":2}";
    CHECK(srv_json_viewer_msg(rs, strlen(rs), &m, &e) && m.width == 800 && m.dpr == 2);
    const char *ack = "{\"type\":\"ack\",\"frame\":99}";
    CHECK(srv_json_viewer_msg(ack, strlen(ack), &m, &e) && m.type == SRV_VIEWER_ACK &&
          m.frame == 99);
    const char *bad[] = {
        "{\"type\":\"camera\",\"position\":[1,2,3]}",    /* no seq */
        "{\"type\":\"camera\",\"seq\":-1}",              /* negative seq */
        "{\"type\":\"camera\",\"seq\":1,\"evil\":true}", /* unknown field */
        "{\"type\":\"resize\",\"width\":800}",           /* no height */
        "{\"type\":\"resize\",\"width\":800,\"height\":600,\"dpr\":100}",
        "{\"type\":\"ack\"}",
        "{\"type\":\"ack\",\"frame\":1.5}",
        "{\"type\":\"hello\"}",
        "{\"seq\":1}",
        "[]",
        "{",
        "",
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        CHECKF(!srv_json_viewer_msg(bad[i], strlen(bad[i]), &m, &e), "'%s' was accepted", bad[i]);
    char big[SRV_VIEWER_MSG_MAX + 10];
    memset(big, ' ', sizeof big);
    memcpy(big, "{\"type\":\"ack\",\"frame\":1}", 24);
    CHECK(!srv_json_viewer_msg(big, sizeof big, &m, &e));
}

/* The quality message: both caps required, each 1..N or null (no cap), nothing else. */
static void test_quality_message(void)
{
    srv_viewer_msg m;
    srv_api_error e;
    const char *q = "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":30}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) && m.type == SRV_VIEWER_QUALITY &&
          m.jpeg_cap == 75 && m.fps_cap == 30);
    q = "{\"max_fps\":null,\"type\":\"quality\",\"jpeg\":null}";
    CHECKF(srv_json_viewer_msg(q, strlen(q), &m, &e) && m.type == SRV_VIEWER_QUALITY &&
               m.jpeg_cap == 0 && m.fps_cap == 0,
           "null: no cap (%s)", e.message);
    q = "{\"type\":\"quality\",\"jpeg\":1,\"max_fps\":240}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) && m.jpeg_cap == 1 && m.fps_cap == 240);
    q = "{\"type\":\"quality\",\"jpeg\":100,\"max_fps\":1}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) && m.jpeg_cap == 100 && m.fps_cap == 1);
    const char *bad[] = {
        "{\"type\":\"quality\"}",
        "{\"type\":\"quality\",\"jpeg\":75}",
        "{\"type\":\"quality\",\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":0,\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":101,\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":75.5,\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":\"75\",\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":-1,\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":0}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":241}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":true}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":[30]}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":30,\"fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":30,\"jpeg\":50}",
        "{\"type\":\"Quality\",\"jpeg\":75,\"max_fps\":30}",
        "{\"type\":\"quality\",\"jpeg\":75,\"max_fps\":30",
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        CHECKF(!srv_json_viewer_msg(bad[i], strlen(bad[i]), &m, &e) && e.status == 400,
               "rejected: %s", bad[i]);
}

/* The video message: codec and max_kbps required (each may be null); malformed ones fail the
 * parse (the connection closes), while an unknown codec or a cap out of range parse and are then
 * refused by srv_viewer_video_request (an error message; the viewer keeps JPEG). */
static void test_video_message(void)
{
    srv_viewer_msg m;
    srv_api_error e;
    unsigned format, kbps;
    char why[160];
    const char *q = "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":3000}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) && m.type == SRV_VIEWER_VIDEO);
    CHECK(srv_viewer_video_request(&m, &format, &kbps, why, sizeof why) &&
          format == PROTO_FORMAT_VP9 && kbps == 3000);
    q = "{\"type\":\"video\",\"codec\":\"vp8\",\"max_kbps\":null}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) &&
          srv_viewer_video_request(&m, &format, &kbps, why, sizeof why) &&
          format == PROTO_FORMAT_VP8 && kbps == 0);
    q = "{\"type\":\"video\",\"codec\":null,\"max_kbps\":null}";
    CHECK(srv_json_viewer_msg(q, strlen(q), &m, &e) &&
          srv_viewer_video_request(&m, &format, &kbps, why, sizeof why) &&
          format == PROTO_FORMAT_JPEG);
    const char *refused[] = {
        "{\"type\":\"video\",\"codec\":\"h264\",\"max_kbps\":null}",
        "{\"type\":\"video\",\"codec\":\"av1\",\"max_kbps\":null}",
        "{\"type\":\"video\",\"codec\":\"VP9\",\"max_kbps\":null}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":0}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":49}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":100001}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":1e12}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":-5}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":500.5}",
    };
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        CHECKF(srv_json_viewer_msg(refused[i], strlen(refused[i]), &m, &e), "parses: %s",
               refused[i]);
        why[0] = 0;
        CHECKF(!srv_viewer_video_request(&m, &format, &kbps, why, sizeof why) && why[0] &&
                   !strchr(why, '"'),
               "refused: %s", refused[i]);
    }
    const char *bad[] = {
        "{\"type\":\"video\"}",
        "{\"type\":\"video\",\"codec\":\"vp9\"}",
        "{\"type\":\"video\",\"max_kbps\":100}",
        "{\"type\":\"video\",\"codec\":9,\"max_kbps\":100}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":\"100\"}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"max_kbps\":100,\"fps\":1}",
        "{\"type\":\"video\",\"codec\":\"vp9\",\"codec\":\"vp8\",\"max_kbps\":100}",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        CHECKF(!srv_json_viewer_msg(bad[i], strlen(bad[i]), &m, &e), "rejects: %s", bad[i]);
}

int main(void)
{
    test_viewer_messages();
    test_quality_message();
    test_video_message();
    return test_finish();
}
