/* A C interface to the device side of a local-model session (remote/local_model.h's
 * LocalRenderer), for clients in other languages: the Python package loads it with
 * ctypes (clients/python/src/hapticd/local_model.py). Built as
 * build/lib/libhapticd_local_model.so.
 *
 * Messages go in as their protobuf encodings (hapticd.v1.OpenSession, hapticd.v1.
 * LocalModel), so the settings and the model are read by the same code the server and
 * hapticd-proxy use. Functions that can fail return a negative value or NULL and write
 * a message naming the bad field into error (error_size bytes, NUL-terminated). */
#ifndef HAPTICD_LOCAL_MODEL_C_API_H
#define HAPTICD_LOCAL_MODEL_C_API_H

#include <stddef.h>
#include <stdint.h>

/* The library hides everything else. */
#define HAPTICD_LOCAL_MODEL_API __attribute__((visibility("default")))

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hapticd_local_renderer hapticd_local_renderer;

/* A renderer for the session that open_session (an encoded OpenSession, impedance)
 * asks for, its avatar at the request's start. NULL on a bad request. */
HAPTICD_LOCAL_MODEL_API hapticd_local_renderer* hapticd_local_renderer_new(const uint8_t* open_session, size_t size, char* error,
                                                   size_t error_size);
HAPTICD_LOCAL_MODEL_API void hapticd_local_renderer_free(hapticd_local_renderer* renderer);

/* Renders from the model in model (an encoded LocalModel) from the next tick, its
 * kinematic objects moved on to now_s (the session's clock). 1: taken; 0: not newer
 * than the one held; -1: it does not decode (the model held stays). */
HAPTICD_LOCAL_MODEL_API int hapticd_local_renderer_accept(hapticd_local_renderer* renderer, const uint8_t* model, size_t size, double now_s,
                                  char* error, size_t error_size);

/* One tick of dt s: the handle at p (m), moving at v (m/s), after f_held (N) was
 * rendered; writes the force to render (N), the avatar (m), whether it touches, and the
 * touched surface's own velocity at the avatar (m/s; zero when not touching or the
 * surface is still: what hapticd_device_channel_surface_velocity takes). */
HAPTICD_LOCAL_MODEL_API void hapticd_local_renderer_tick(hapticd_local_renderer* renderer, const double p[3], const double v[3],
                                 const double f_held[3], double dt, double force[3], double avatar[3], int* contact,
                                 double v_surface[3]);

/* The model rendered from (0: none yet), and whether the avatar lies within its ball. */
HAPTICD_LOCAL_MODEL_API uint64_t hapticd_local_renderer_version(const hapticd_local_renderer* renderer);
HAPTICD_LOCAL_MODEL_API int hapticd_local_renderer_covers(const hapticd_local_renderer* renderer, const double p[3]);

#ifdef __cplusplus
}
#endif

#endif
