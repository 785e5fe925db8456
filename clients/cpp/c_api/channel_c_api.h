/* A C interface to the device's end of a session's channel (remote/channel_ends.h's
 * DeviceEnd: two-port time-domain passivity; remote/deadband.h's StateDeadband: the
 * perceptual deadband of its states), for clients in other languages: the Python
 * package's DeviceSession loads it with ctypes (clients/python/src/hapticd/device.py).
 * Part of build/lib/libhapticd_local_model.so; errors as in local_model_c_api.h. */
#ifndef HAPTICD_CHANNEL_C_API_H
#define HAPTICD_CHANNEL_C_API_H

#include <stddef.h>
#include <stdint.h>

#include "clients/cpp/c_api/local_model_c_api.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hapticd_device_channel hapticd_device_channel;

/* The device's end for the session open_session (an encoded OpenSession, impedance)
 * asks for: its passivity port (the damper acts under open_session.tdpa, else it only
 * observes), predicting with the handle's mass (kg, > 0), the handle at the request's
 * start; and its states' deadband (the request's fraction, floors and keep-alive; none
 * when its deadband is 0). NULL on a bad request or mass. */
HAPTICD_LOCAL_MODEL_API hapticd_device_channel* hapticd_device_channel_new(const uint8_t* open_session, size_t size,
                                                                           double mass, char* error,
                                                                           size_t error_size);
HAPTICD_LOCAL_MODEL_API void hapticd_device_channel_free(hapticd_device_channel* channel);

/* A sample at the start of a tick, at t s (the device's clock, non-decreasing): the
 * handle at p (m) moving at v (m/s) after f_held (N) was held since the last sample, whose
 * work over the move the port observes (a local-model session's: relative to the
 * surface's motion since then, at the velocity hapticd_device_channel_surface_velocity
 * last gave). Writes the port's energies (J: in, out) into
 * energy and returns what becomes of the state: 1 send, 2 send as a keep-alive, 0 the
 * deadband holds it back. */
HAPTICD_LOCAL_MODEL_API int hapticd_device_channel_sample(hapticd_device_channel* channel, double t, const double p[3],
                                                          const double v[3], const double f_held[3],
                                                          double energy[2]);

/* A local-model session's device, each tick after rendering: the velocity (m/s) of the
 * surface its force pushes from (hapticd_local_renderer_tick's v_surface; non-finite:
 * zero). Its port, a one-port on the local rendering, predicts and observes relative to
 * it (remote/channel_ends.h). */
HAPTICD_LOCAL_MODEL_API void hapticd_device_channel_surface_velocity(hapticd_device_channel* channel,
                                                                     const double v_surface[3]);

/* The force (N) to hold over the coming dt s (> 0), for force: saturated at the session's
 * max_force (zero when not finite), then under tdpa limited by the port to what the
 * server's newest energy_in (J) allows (a local-model session's: to what the hand put
 * into its local rendering; server_energy_in is not used). Returns 1 when the port cut it. */
HAPTICD_LOCAL_MODEL_API int hapticd_device_channel_limit(hapticd_device_channel* channel, double server_energy_in,
                                                         const double force[3], double dt, double out[3]);

#ifdef __cplusplus
}
#endif

#endif
