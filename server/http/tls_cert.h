/* tls_cert.h: the daemon's own certificate and private key (probecast serve --tls-cert and
 * --tls-key), for deployments without a TLS proxy in front.
 *
 * Both PEM files are read once at start and checked with OpenSSL (the library libwebsockets
 * uses) before the GPU starts or anything listens: a missing, unreadable, non-PEM or encrypted
 * file, or a key that is not the certificate's, is one sentence naming the flag and the file.
 * The HTTP API gets the PEM text (libmicrohttpd, GnuTLS), the stream the paths (libwebsockets
 * loads the whole certificate chain only from a file).
 */
#ifndef SRV_TLS_CERT_H
#define SRV_TLS_CERT_H

#include <stdbool.h>
#include <stddef.h>
#include <time.h>

typedef enum srv_tls_result {
    SRV_TLS_OK = 0,
    SRV_TLS_ERR_READ,      /* a file is missing, unreadable, empty or too large */
    SRV_TLS_ERR_NOT_PEM,   /* no PEM certificate, or no PEM private key, in the file */
    SRV_TLS_ERR_ENCRYPTED, /* the key needs a passphrase */
    SRV_TLS_ERR_MISMATCH,  /* the key is not the certificate's */
} srv_tls_result;

typedef struct srv_tls_cert {
    const char *cert_path, *key_path; /* as given (borrowed) */
    char *cert_pem, *key_pem;         /* the files' text, NUL-terminated (owned) */
    char subject[256];                /* the certificate's subject, one line */
    time_t not_before, not_after;     /* its validity */
} srv_tls_cert;

/* Reads and checks the pair into *t. On failure *t holds nothing and err (one sentence, naming
 * the flag and the file) says why. */
srv_tls_result srv_tls_cert_load(srv_tls_cert *t, const char *cert_path, const char *key_path,
                                 char *err, size_t errlen);
/* Wipes and frees what t owns (idempotent). */
void srv_tls_cert_dispose(srv_tls_cert *t);
const char *srv_tls_strerror(srv_tls_result r);

#endif
