/* access.h: who may connect — plain string checks shared by the stream and the HTTP API (no
 * network state): tokens compared in constant time, Host[:port] parsing, and whether a browser
 * page's Origin is the API's own. */
#ifndef SRV_ACCESS_H
#define SRV_ACCESS_H

#include <stdbool.h>
#include <stddef.h>

/* given (given_len bytes, not NUL-terminated) equals token; the time depends on given_len only.
 * An empty token never matches. */
bool srv_token_equal(const char *given, size_t given_len, const char *token);
/* localhost, 127.x.y.z, ::1 or [::1]. */
bool srv_host_is_loopback(const char *host);
/* Splits len bytes of "host[:port]" or "[v6]:port" into host (brackets removed) and *port (dflt
 * when absent). False for a malformed value or a port outside 1..65535. */
bool srv_split_host_port(const char *s, size_t len, char *host, size_t hostlen, unsigned *port,
                         unsigned dflt);
/* Whether a browser page at origin may use the API at http_host:http_port (loopback names count
 * as one host; when the API listens on every address, the page must come from the host the
 * request was sent to, request_host). */
bool srv_ws_origin_allowed(const char *origin, const char *http_host, unsigned http_port,
                           const char *request_host);

/* Whether a request's Host header (host[:port]) names this server: a loopback name, an IP address
 * literal, or one of public_names (comma-separated, may be NULL). A page that rebinds its own DNS
 * name to this address still sends its own name as Host, so it is refused here. */
bool srv_host_allowed(const char *host_header, const char *public_names);
/* Whether host_header (host[:port]) is one of public_names: a name the operator gave for a
 * public origin (behind a TLS proxy). */
bool srv_host_is_public(const char *host_header, const char *public_names);
/* Whether a request with this Origin may change something: no Origin (not a browser), or a page
 * of this very server: the same host and port as host_header, which srv_host_allowed accepts. */
bool srv_origin_same_host(const char *origin, const char *host_header, const char *public_names);

#endif
