/* tls_cert.c: reading and checking --tls-cert and --tls-key with OpenSSL's PEM and X.509 code. */
#include "server/http/tls_cert.h"

#include <errno.h>
#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define PEM_FILE_MAX (1u << 20) /* a certificate chain is a few KiB */

static const char *const result_names[] = {
    [SRV_TLS_OK] = "ok",
    [SRV_TLS_ERR_READ] = "cannot read the file",
    [SRV_TLS_ERR_NOT_PEM] = "not a PEM certificate or private key",
    [SRV_TLS_ERR_ENCRYPTED] = "the private key is encrypted",
    [SRV_TLS_ERR_MISMATCH] = "the private key does not belong to the certificate",
};

const char *srv_tls_strerror(srv_tls_result r)
{
    return (unsigned)r < sizeof result_names / sizeof result_names[0] ? result_names[r]
                                                                      : "unknown error";
}

/* The whole file as a NUL-terminated string (malloc'd), or NULL with err set. */
static char *read_pem_file(const char *flag, const char *path, size_t *len, char *err,
                           size_t errlen)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat sb;
    if (fd < 0 || fstat(fd, &sb) != 0) {
        snprintf(err, errlen, "cannot read the %s file '%s': %s", flag, path, strerror(errno));
        if (fd >= 0) close(fd);
        return NULL;
    }
    if (!S_ISREG(sb.st_mode) || sb.st_size <= 0 || (uint64_t)sb.st_size > PEM_FILE_MAX) {
        snprintf(err, errlen, "the %s file '%s' is %s", flag, path,
                 !S_ISREG(sb.st_mode) ? "not a regular file"
                 : sb.st_size <= 0    ? "empty"
                                      : "larger than 1 MiB, too large for a PEM file");
        close(fd);
        return NULL;
    }
    char *buf = malloc((size_t)sb.st_size + 1);
    if (!buf) abort();
    size_t n = 0;
    while (n < (size_t)sb.st_size) {
        ssize_t k = read(fd, buf + n, (size_t)sb.st_size - n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) break;
        n += (size_t)k;
    }
    int read_errno = errno;
    close(fd);
    if (n != (size_t)sb.st_size) {
        snprintf(err, errlen, "cannot read the %s file '%s': %s", flag, path,
                 n < (size_t)sb.st_size && read_errno ? strerror(read_errno) : "short read");
        OPENSSL_cleanse(buf, n);
        free(buf);
        return NULL;
    }
    buf[n] = 0;
    *len = n;
    return buf;
}

/* OpenSSL's reason for the last failure, for a damaged PEM block. */
static const char *openssl_reason(void)
{
    const char *r = ERR_reason_error_string(ERR_peek_last_error());
    return r ? r : "unknown";
}

/* Refuses to ask for a passphrase (OpenSSL would prompt on the terminal) and notes it was asked. */
static int no_passphrase(char *buf, int size, int rwflag, void *asked)
{
    (void)buf;
    (void)size;
    (void)rwflag;
    *(bool *)asked = true;
    return -1;
}

static time_t asn1_time(const ASN1_TIME *t)
{
    struct tm tm;
    memset(&tm, 0, sizeof tm);
    return t && ASN1_TIME_to_tm(t, &tm) == 1 ? timegm(&tm) : 0;
}

srv_tls_result srv_tls_cert_load(srv_tls_cert *t, const char *cert_path, const char *key_path,
                                 char *err, size_t errlen)
{
    memset(t, 0, sizeof *t);
    t->cert_path = cert_path;
    t->key_path = key_path;
    size_t cert_len = 0, key_len = 0;
    srv_tls_result r = SRV_TLS_ERR_READ;
    X509 *x = NULL;
    EVP_PKEY *pkey = NULL;
    BIO *bio = NULL;
    ERR_clear_error();
    t->cert_pem = read_pem_file("--tls-cert", cert_path, &cert_len, err, errlen);
    if (!t->cert_pem) goto fail;
    t->key_pem = read_pem_file("--tls-key", key_path, &key_len, err, errlen);
    if (!t->key_pem) goto fail;

    /* the first certificate of the file is the server's (the rest is its chain) */
    bio = BIO_new_mem_buf(t->cert_pem, (int)cert_len);
    if (!bio) abort();
    x = PEM_read_bio_X509(bio, NULL, NULL, NULL);
    BIO_free(bio);
    if (!x) {
        r = SRV_TLS_ERR_NOT_PEM;
        if (strstr(t->cert_pem, "-----BEGIN CERTIFICATE-----"))
            snprintf(err, errlen, "the --tls-cert file '%s' holds a damaged PEM certificate (%s)",
                     cert_path, openssl_reason());
        else
            snprintf(err, errlen,
                     "the --tls-cert file '%s' holds no PEM certificate (a -----BEGIN "
                     "CERTIFICATE----- block)",
                     cert_path);
        goto fail;
    }
    bool asked = false;
    bio = BIO_new_mem_buf(t->key_pem, (int)key_len);
    if (!bio) abort();
    pkey = PEM_read_bio_PrivateKey(bio, NULL, no_passphrase, &asked);
    BIO_free(bio);
    if (!pkey) {
        if (asked) {
            r = SRV_TLS_ERR_ENCRYPTED;
            snprintf(err, errlen,
                     "the --tls-key file '%s' is encrypted; give the key without a passphrase "
                     "(openssl pkey -in ENCRYPTED.pem -out KEY.pem, mode 0600)",
                     key_path);
        } else if (strstr(t->key_pem, "PRIVATE KEY-----")) {
            r = SRV_TLS_ERR_NOT_PEM;
            snprintf(err, errlen, "the --tls-key file '%s' holds a damaged PEM private key (%s)",
                     key_path, openssl_reason());
        } else {
            r = SRV_TLS_ERR_NOT_PEM;
            snprintf(err, errlen,
                     "the --tls-key file '%s' holds no PEM private key (a -----BEGIN PRIVATE "
                     "KEY----- block)",
                     key_path);
        }
        goto fail;
    }
    if (X509_check_private_key(x, pkey) != 1) {
        r = SRV_TLS_ERR_MISMATCH;
        snprintf(err, errlen,
                 "the --tls-key file '%s' is not the private key of the certificate in the "
                 "--tls-cert file '%s'",
                 key_path, cert_path);
        goto fail;
    }
    X509_NAME_oneline(X509_get_subject_name(x), t->subject, sizeof t->subject);
    t->not_before = asn1_time(X509_get0_notBefore(x));
    t->not_after = asn1_time(X509_get0_notAfter(x));
    X509_free(x);
    EVP_PKEY_free(pkey);
    ERR_clear_error();
    return SRV_TLS_OK;

fail:
    X509_free(x);
    EVP_PKEY_free(pkey);
    ERR_clear_error();
    srv_tls_cert_dispose(t);
    return r;
}

void srv_tls_cert_dispose(srv_tls_cert *t)
{
    if (!t) return;
    if (t->key_pem) {
        OPENSSL_cleanse(t->key_pem, strlen(t->key_pem));
        free(t->key_pem);
    }
    free(t->cert_pem);
    memset(t, 0, sizeof *t);
}
