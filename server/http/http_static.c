/* http_static.c: the viewer's files (web/) served at /, or a built-in page without them. */
#include "server/http/http_internal.h"
#include "server/http/http_response.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <microhttpd.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "server/api/api_json.h"
#include "server/base/clock.h"
#include "server/base/log.h"
#include "server/http/stats_report.h"

#define STATIC_FILE_MAX (64u << 20)

/* ---- static files ------------------------------------------------------------------------ */

static const char *content_type_for(const char *path)
{
    static const struct {
        const char *ext, *type;
    } t[] = {{".html", "text/html; charset=utf-8"},
             {".js", "text/javascript; charset=utf-8"},
             {".mjs", "text/javascript; charset=utf-8"},
             {".css", "text/css; charset=utf-8"},
             {".json", "application/json"},
             {".png", "image/png"},
             {".jpg", "image/jpeg"},
             {".jpeg", "image/jpeg"},
             {".svg", "image/svg+xml"},
             {".ico", "image/x-icon"},
             {".wasm", "application/wasm"},
             {".txt", "text/plain; charset=utf-8"},
             {".map", "application/json"},
             {".yaml", "application/yaml"},
             {".webp", "image/webp"}};
    const char *dot = strrchr(path, '.');
    for (size_t i = 0; dot && i < sizeof t / sizeof t[0]; i++)
        if (strcasecmp(dot, t[i].ext) == 0) return t[i].type;
    return "application/octet-stream";
}

/* Resolves url below the web folder: no "..", no hidden files, and the real path (symlinks
 * followed) must stay inside the folder. */
static bool resolve_static(srv_http *h, const char *url, char *out, size_t outlen)
{
    if (!h->have_web_dir || url[0] != '/' || strlen(url) > 512) return false;
    if (strstr(url, "/.") || strchr(url, '\\') || strstr(url, "//")) return false;
    char joined[PATH_MAX];
    int n = snprintf(joined, sizeof joined, "%s%s", h->web_dir,
                     strcmp(url, "/") == 0 ? "/index.html" : url);
    if (n < 0 || (size_t)n >= sizeof joined) return false;
    char real[PATH_MAX];
    if (!realpath(joined, real)) return false;
    size_t root = strlen(h->web_dir);
    if (strncmp(real, h->web_dir, root) != 0 || real[root] != '/') return false;
    snprintf(out, outlen, "%s", real);
    return true;
}

enum MHD_Result srv_http_handle_static(srv_http *h, struct MHD_Connection *conn, request *rq,
                                       const char *url)
{
    char path[PATH_MAX];
    if (!resolve_static(h, url, path, sizeof path)) {
        if (strcmp(url, "/") == 0 || strcmp(url, "/index.html") == 0) {
            const char *page = srv_placeholder_page();
            char *copy = strdup(page);
            if (!copy) abort();
            return srv_http_respond(h, conn, rq, 200, "text/html; charset=utf-8", copy,
                                    strlen(copy));
        }
        return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "No such file.");
    }
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat sb;
    if (fd < 0 || fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode) ||
        (size_t)sb.st_size > STATIC_FILE_MAX) {
        if (fd >= 0) close(fd);
        return srv_http_respond_error(h, conn, rq, 404, SRV_ERR_NOT_FOUND, "No such file.");
    }
    struct MHD_Response *resp = MHD_create_response_from_fd((uint64_t)sb.st_size, fd);
    if (!resp) {
        close(fd);
        return MHD_NO;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, content_type_for(path));
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-cache");
    enum MHD_Result r = MHD_queue_response(conn, 200, resp);
    MHD_destroy_response(resp);
    srv_http_count_status(h, rq, 200);
    rq->responded = true;
    return r;
}
