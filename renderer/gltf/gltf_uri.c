/* gltf_uri.c: which external files a glTF file may name, and reading them (see gltf_import.h);
 * rd_gltf_load_file (gltf_loader.h), which reads the file and loads it from memory with its
 * folder as the base. A URI is opened only when it is relative, stays below the base folder
 * and names a regular file; loading from memory without a base folder opens nothing. */
#include "renderer/gltf/gltf_import.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char *dup_or_die(const char *s, size_t extra)
{
    size_t n = strlen(s);
    char *r = malloc(n + extra + 1);
    if (!r) {
        fprintf(stderr, "probecast: out of memory (%zu bytes)\n", n + extra + 1);
        abort();
    }
    memcpy(r, s, n + 1);
    return r;
}

void rd_gltf_files_init(rd_gltf_files *f, const char *base_dir)
{
    memset(f, 0, sizeof *f);
    if (!base_dir) return;
    f->allowed = true;
    f->base = dup_or_die(base_dir[0] ? base_dir : ".", 0);
    f->prefix = dup_or_die(f->base, 1);
    f->prefix_len = strlen(f->prefix);
    if (f->prefix[f->prefix_len - 1] != '/')
        f->prefix[f->prefix_len++] = '/', f->prefix[f->prefix_len] = '\0';
}

void rd_gltf_files_dispose(rd_gltf_files *f)
{
    free(f->base);
    free(f->prefix);
    memset(f, 0, sizeof *f);
}

void rd_gltf_errno_text(int e, char *out, size_t outlen)
{
    char buf[256];
    snprintf(out, outlen, "%s", strerror_r(e, buf, sizeof buf)); /* GNU variant returns the text */
}

const char *rd_gltf_uri_refusal(const rd_gltf_files *f, const char *rel, size_t len)
{
    if (!f->allowed)
        return "a file uploaded alone cannot refer to other files: upload a .glb, or a .gltf "
               "whose buffers and images are embedded as data: URIs";
    if (len == 0) return "the URI is empty";
    if (memchr(rel, '\0', len)) return "the URI contains a NUL character";
    if (len >= 5 && memcmp(rel, "data:", 5) == 0)
        return "only base64 data: URIs of a known media type are supported";
    if (rel[0] == '/') return "absolute paths are not allowed";
    if (strstr(rel, "://")) return "only relative file paths are allowed";
    for (const char *c = rel, *end = rel + len; c <= end;) {
        const char *slash = memchr(c, '/', (size_t)(end - c));
        size_t n = (size_t)((slash ? slash : end) - c);
        if (n == 2 && c[0] == '.' && c[1] == '.')
            return "the URI leaves the asset folder (it contains '..')";
        if (!slash) break;
        c = slash + 1;
    }
    return NULL;
}

bool rd_gltf_files_check_path(rd_gltf_files *f, const char *path, size_t len, size_t *rel)
{
    if (!f->allowed || len < f->prefix_len || memcmp(path, f->prefix, f->prefix_len) != 0) {
        const char *why = f->last_refusal[0] ? NULL : rd_gltf_uri_refusal(f, path, len);
        if (why) snprintf(f->last_refusal, sizeof f->last_refusal, "%s", why);
        return false;
    }
    *rel = f->prefix_len;
    const char *why = rd_gltf_uri_refusal(f, path + f->prefix_len, len - f->prefix_len);
    if (why) {
        snprintf(f->last_refusal, sizeof f->last_refusal, "%s", why);
        return false;
    }
    return true;
}

bool rd_gltf_files_exists(rd_gltf_files *f, const char *path, size_t len)
{
    size_t rel;
    struct stat st;
    return rd_gltf_files_check_path(f, path, len, &rel) && stat(path, &st) == 0 &&
           S_ISREG(st.st_mode);
}

char *rd_gltf_files_join(const rd_gltf_files *f, const char *rel, size_t len)
{
    char *r = dup_or_die(f->prefix, len);
    memcpy(r + f->prefix_len, rel, len);
    r[f->prefix_len + len] = '\0';
    return r;
}

rd_gltf_read_status rd_gltf_read_file(const char *path, uint64_t max_size,
                                      unsigned char *(*alloc)(void *user, size_t size), void *user,
                                      char *why, size_t whylen)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
        rd_gltf_errno_text(errno, why, whylen);
        return RD_GLTF_READ_FAILED;
    }
    struct stat st;
    rd_gltf_read_status status = RD_GLTF_READ_FAILED;
    if (fstat(fd, &st) != 0) {
        rd_gltf_errno_text(errno, why, whylen);
    } else if (!S_ISREG(st.st_mode)) {
        snprintf(why, whylen, "it is not a regular file");
    } else if ((uint64_t)st.st_size > max_size) {
        snprintf(why, whylen, "it is too large (%lld bytes)", (long long)st.st_size);
        status = RD_GLTF_READ_TOO_LARGE;
    } else {
        size_t size = (size_t)st.st_size, done = 0;
        unsigned char *out = alloc(user, size);
        if (!out && size > 0) {
            close(fd);
            return RD_GLTF_READ_NO_MEMORY;
        }
        while (done < size) {
            ssize_t n = read(fd, out + done, size - done);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                if (n < 0)
                    rd_gltf_errno_text(errno, why, whylen);
                else
                    snprintf(why, whylen, "it shrank while being read");
                break;
            }
            done += (size_t)n;
        }
        if (done == size) status = RD_GLTF_READ_OK;
    }
    close(fd);
    return status;
}

typedef struct file_bytes {
    unsigned char *data;
    size_t size;
} file_bytes;

static unsigned char *malloc_alloc(void *user, size_t size)
{
    file_bytes *f = user;
    f->size = size;
    f->data = malloc(size ? size : 1);
    return f->data;
}

rd_gltf_read_status rd_gltf_read_file_malloc(const char *path, uint64_t max_size,
                                             unsigned char **data, size_t *size, char *why,
                                             size_t whylen)
{
    file_bytes f = {NULL, 0};
    rd_gltf_read_status st = rd_gltf_read_file(path, max_size, malloc_alloc, &f, why, whylen);
    if (st != RD_GLTF_READ_OK) {
        free(f.data);
        f.data = NULL;
    }
    *data = f.data;
    *size = f.size;
    return st;
}

/* Fails before loading: out is left destroyed (zeroed) and err holds the message. */
static rd_gltf_result refuse(rd_scene *out, char *err, size_t errlen, rd_gltf_result code,
                             const char *fmt, ...) __attribute__((format(printf, 5, 6)));
static rd_gltf_result refuse(rd_scene *out, char *err, size_t errlen, rd_gltf_result code,
                             const char *fmt, ...)
{
    rd_scene_init(out);
    rd_scene_destroy(out);
    va_list ap;
    va_start(ap, fmt);
    char *msg = NULL;
    int n = vasprintf(&msg, fmt, ap);
    va_end(ap);
    if (n < 0) {
        fprintf(stderr, "probecast: out of memory (a message)\n");
        abort();
    }
    rd_gltf_write_text(msg, (size_t)n, err, errlen);
    free(msg);
    return code;
}

rd_gltf_result rd_gltf_load_file(const char *path, const rd_gltf_options *opt, rd_scene *out,
                                 char *err, size_t errlen)
{
    if (!out) {
        rd_gltf_write_text("no output scene was given", 25, err, errlen);
        return RD_GLTF_ERR_INVALID;
    }
    if (!path || !path[0])
        return refuse(out, err, errlen, RD_GLTF_ERR_IO, "no file name was given");
    unsigned char *data;
    size_t size;
    char why[256] = "";
    rd_gltf_read_status st =
        rd_gltf_read_file_malloc(path, 0xffffffffull, &data, &size, why, sizeof why);
    if (st == RD_GLTF_READ_NO_MEMORY)
        return refuse(out, err, errlen, RD_GLTF_ERR_TOO_LARGE,
                      "the file needs more memory than is available");
    if (st != RD_GLTF_READ_OK)
        return refuse(out, err, errlen,
                      st == RD_GLTF_READ_TOO_LARGE ? RD_GLTF_ERR_TOO_LARGE : RD_GLTF_ERR_IO,
                      "'%s' could not be read: %s", path, why);
    const char *slash = strrchr(path, '/');
    char *base = slash == NULL   ? strdup(".")
                 : slash == path ? strdup("/")
                                 : strndup(path, (size_t)(slash - path));
    if (!base) {
        fprintf(stderr, "probecast: out of memory (a path)\n");
        abort();
    }
    rd_gltf_result r = rd_gltf_load_memory(data, size, base, opt, out, err, errlen);
    free(base);
    free(data);
    return r;
}
