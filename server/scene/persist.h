/* persist.h: the daemon's state on disk (--data-dir), so that a restart resumes where it was.
 *
 * DIR/scene.bin        the bytes of the last accepted uploaded scene (.glb or .gltf)
 * DIR/scene.json       {"generation": G, "size": N} written after scene.bin
 * DIR/environment.EXT  the environment image of PUT /v1/environment as uploaded: EXT is hdr
 *                      (Radiance) or exr (OpenEXR), one file only; gone after DELETE
 * DIR/state.json       {"version": 1, "generation": G, "source": S, "state": {camera,
 *                      settings, lights, nodes}} (scene_state.h's document)
 * Every file is written as a temporary file, fsync'ed, renamed over the old one, and the
 * folder fsync'ed, so a crash leaves the old or the new file, never a torn one. The saved
 * state applies only to the scene it was saved with (same generation and source).
 *
 * Writes happen on the persister's own thread: posting never blocks on the disk. Scene bytes
 * are written as they come; state documents are coalesced (the newest wins) and written at
 * most a few times a second. srv_persist_close writes whatever is pending.
 */
#ifndef SRV_PERSIST_H
#define SRV_PERSIST_H

#include <cjson/cJSON.h>
#include <stddef.h>
#include <stdint.h>

typedef struct srv_persist srv_persist;

/* Creates dir if needed and starts the writer thread. NULL with a message on failure. */
srv_persist *srv_persist_open(const char *dir, char *err, size_t errlen);
/* Writes pending data, stops the thread and frees p (NULL is fine). */
void srv_persist_close(srv_persist *p);

typedef struct srv_saved {
    uint8_t *environment; /* malloc'd bytes of the saved environment image, or NULL */
    size_t environment_size;
    uint8_t *scene; /* malloc'd bytes of the saved upload, or NULL */
    size_t scene_size;
    uint64_t scene_generation;
    cJSON *state; /* the "state" member of state.json, or NULL */
    uint64_t state_generation;
    char state_source[128];
} srv_saved;

/* Reads what a previous run saved (missing files are not an error; unreadable or
 * inconsistent ones are skipped with a warning). Free with srv_saved_free. */
void srv_persist_load(srv_persist *p, srv_saved *out);
void srv_saved_free(srv_saved *s);

/* Queues the bytes of an accepted upload (ownership of bytes passes to p; free()d). */
void srv_persist_post_scene(srv_persist *p, uint64_t generation, uint8_t *bytes, size_t size);
/* Queues the bytes of an accepted environment image (taken, free()d), or its removal (NULL).
 * The file is named after the image's format (rd_env_image_format); the other one goes. */
void srv_persist_post_environment(srv_persist *p, uint8_t *bytes, size_t size);
/* Queues a state document (ownership of doc passes to p). */
void srv_persist_post_state(srv_persist *p, uint64_t generation, const char *source, cJSON *doc);

/* Writes size bytes to path atomically (temporary file, fsync, rename, fsync of the folder).
 * Returns 0 or an errno value. */
int srv_write_file_atomic(const char *path, const void *data, size_t size);

#endif
