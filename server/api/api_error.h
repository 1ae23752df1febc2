/* api_error.h: how the API says no: an error (HTTP status, a stable code, one sentence) and the
 * JSON body every error response carries, {"error": code, "message": sentence}.
 *
 * Plain C and cJSON only, so that generic parts (the mailbox) can answer with an error without
 * knowing the API's documents (api_json.h) or the renderer types behind them.
 */
#ifndef SRV_API_ERROR_H
#define SRV_API_ERROR_H

/* Error codes (the "error" member of every error body). */
#define SRV_ERR_MALFORMED_JSON "malformed_json"
#define SRV_ERR_INVALID_FIELD "invalid_field"
#define SRV_ERR_NOT_FOUND "not_found"
#define SRV_ERR_METHOD "method_not_allowed"
#define SRV_ERR_UNAUTHORIZED "unauthorized"
#define SRV_ERR_FORBIDDEN "forbidden"
#define SRV_ERR_TOO_LARGE "payload_too_large"
#define SRV_ERR_MEDIA_TYPE "unsupported_media_type"
#define SRV_ERR_INVALID_GLTF "invalid_gltf"
#define SRV_ERR_INVALID_IMAGE "invalid_image"
#define SRV_ERR_UNAVAILABLE "unavailable"
#define SRV_ERR_GPU "gpu_error"
#define SRV_ERR_INTERNAL "internal_error"

/* An API error: HTTP status, a stable code and one sentence. */
typedef struct srv_api_error {
    int status;
    const char *code; /* static string */
    char message[256];
} srv_api_error;

#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
void srv_api_fail(srv_api_error *e, int status, const char *code, const char *fmt, ...);

/* {"error": code, "message": message} as malloc'd text. */
char *srv_json_error_body(const char *code, const char *message);

#endif
