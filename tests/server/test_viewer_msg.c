/* Strict parsing of the stream's viewer messages (server/stream/viewer_msg.h; plain CPU code: no
 * daemon, no GPU). */
#include <string.h>

#include "server/stream/viewer_msg.h"
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

int main(void)
{
    test_viewer_messages();
    test_quality_message();
    return test_finish();
}
