/* Who may connect (server/api/access.c): constant-time token comparison, Host names, and whether a
 * page's Origin may change the server. Plain CPU code. */
#include <string.h>

#include "server/api/access.h"
#include "test_util.h"

int main(void)
{
    CHECK(srv_token_equal("s3cret", 6, "s3cret"));
    CHECK(!srv_token_equal("s3cre", 5, "s3cret"));
    CHECK(!srv_token_equal("s3cret!", 7, "s3cret"));
    CHECK(!srv_token_equal("S3cret", 6, "s3cret"));
    CHECK(!srv_token_equal("", 0, "")); /* an empty token never matches */

    /* Host: loopback names, IP literals and configured names */
    CHECK(srv_host_allowed("127.0.0.1:8080", NULL));
    CHECK(srv_host_allowed("localhost:8080", NULL));
    CHECK(srv_host_allowed("LOCALHOST", NULL));
    CHECK(srv_host_allowed("[::1]:8080", NULL));
    CHECK(srv_host_allowed("192.168.1.5:8080", NULL));
    CHECK(srv_host_allowed("[fe80::1]:8080", NULL));
    CHECK(!srv_host_allowed("evil.example:8080", NULL));
    CHECK(!srv_host_allowed("evil.example", "render.example.org"));
    CHECK(srv_host_allowed("render.example.org", "gpu1,render.example.org"));
    CHECK(srv_host_allowed("Render.Example.Org:443", "gpu1,render.example.org"));
    CHECK(!srv_host_allowed("render.example", "render.example.org"));
    CHECK(!srv_host_allowed("example.org", "render.example.org")); /* no suffix matching */
    CHECK(!srv_host_allowed(NULL, NULL));
    CHECK(!srv_host_allowed("", NULL));
    CHECK(!srv_host_allowed("127.0.0.1:99999", NULL)); /* bad port */
    CHECK(!srv_host_allowed("[::1", NULL));

    /* Origin of a change: none (not a browser), or this server's own page */
    CHECK(srv_origin_same_host(NULL, "127.0.0.1:8080", NULL));
    CHECK(srv_origin_same_host("http://127.0.0.1:8080", "127.0.0.1:8080", NULL));
    CHECK(srv_origin_same_host("http://localhost:8080", "127.0.0.1:8080", NULL));
    CHECK(!srv_origin_same_host("http://127.0.0.1:9999", "127.0.0.1:8080", NULL));
    CHECK(!srv_origin_same_host("http://evil.example:8080", "127.0.0.1:8080", NULL));
    /* DNS rebinding: the page and the Host agree, but the name is not ours */
    CHECK(!srv_origin_same_host("http://evil.example:8080", "evil.example:8080", NULL));
    CHECK(srv_origin_same_host("https://render.example.org", "render.example.org",
                               "render.example.org"));
    CHECK(!srv_origin_same_host("null", "127.0.0.1:8080", NULL));
    CHECK(!srv_origin_same_host("file:///x.html", "127.0.0.1:8080", NULL));

    CHECK(srv_host_is_public("render.example.org:443", "gpu1,render.example.org"));
    CHECK(!srv_host_is_public("127.0.0.1:8081", "render.example.org"));
    CHECK(!srv_host_is_public("127.0.0.1:8081", NULL));

    /* the stream's Origin check (the API's own origin) */
    CHECK(srv_ws_origin_allowed("http://127.0.0.1:8080", "127.0.0.1", 8080, "127.0.0.1:8081"));
    CHECK(!srv_ws_origin_allowed("http://evil.example:8080", "127.0.0.1", 8080, NULL));
    return test_finish();
}
