#include "clients/cpp/c_api/channel_c_api.h"

#include <cmath>
#include <cstdio>
#include <exception>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/proto_convert.h"
#include "server/remote/channel_ends.h"
#include "server/remote/deadband.h"

struct hapticd_device_channel {
  hapticd::remote::DeviceEnd end;
  hapticd::remote::StateDeadband deadband;
  hapticd::remote::DeadbandSettings settings;
  double max_force = 0;
  double period_s = 0;
  double last_t = -1;  // the last sample's time (negative: none yet)
};

namespace {

using hapticd::geometry::Vector3;

void WriteError(char* error, size_t error_size, const char* message) {
  if (error != nullptr && error_size > 0) std::snprintf(error, error_size, "%s", message);
}

Vector3 Read(const double v[3]) { return {v[0], v[1], v[2]}; }

}  // namespace

extern "C" {

hapticd_device_channel* hapticd_device_channel_new(const uint8_t* open_session, size_t size, double mass, char* error,
                                                   size_t error_size) {
  try {
    hapticd::v1::OpenSession open;
    if (!open.ParseFromArray(open_session, static_cast<int>(size))) {
      WriteError(error, error_size, "open_session does not parse as a hapticd.v1.OpenSession");
      return nullptr;
    }
    Vector3 start_W;
    double timeout_s = 0;
    const hapticd::force::SessionSettings settings = hapticd::net::ReadSessionRequest(open, start_W, timeout_s);
    const hapticd::net::ChannelRequest channel = hapticd::net::ReadChannelRequest(open);
    if (settings.device.mode != hapticd::force::DeviceMode::kImpedance) {
      WriteError(error, error_size, "open_session.device_type is admittance; the device's end of the channel is "
                                    "for impedance devices");
      return nullptr;
    }
    if (!(mass > 0 && std::isfinite(mass))) {
      WriteError(error, error_size, "mass must be a finite number > 0 (kg: the handle's)");
      return nullptr;
    }
    auto* made = new hapticd_device_channel{hapticd::remote::DeviceEnd(channel.tdpa, mass,
                                                                      hapticd::net::ReadLocalModelMode(open)),
                                           hapticd::remote::StateDeadband(channel.deadband), channel.deadband,
                                           settings.device.max_force, 1 / settings.device.rate_hz};
    made->end.Reset(start_W);
    return made;
  } catch (const std::exception& e) {
    WriteError(error, error_size, e.what());
    return nullptr;
  }
}

void hapticd_device_channel_free(hapticd_device_channel* channel) { delete channel; }

int hapticd_device_channel_sample(hapticd_device_channel* channel, double t, const double p[3], const double v[3],
                                  const double f_held[3], double energy[2]) {
  channel->end.Sample(Read(p), Read(v), Read(f_held), channel->last_t < 0 ? 0.0 : t - channel->last_t);
  channel->last_t = t;
  energy[0] = channel->end.energy().in;
  energy[1] = channel->end.energy().out;
  if (!channel->settings.on()) return 1;
  switch (channel->deadband.OfferWithKeepalive(t, Read(p), Read(v), channel->settings.keepalive_s,
                                               channel->period_s)) {
    case hapticd::remote::StateVerdict::kSend: return 1;
    case hapticd::remote::StateVerdict::kKeepalive: return 2;
    case hapticd::remote::StateVerdict::kHold: break;
  }
  return 0;
}

void hapticd_device_channel_surface_velocity(hapticd_device_channel* channel, const double v_surface[3]) {
  channel->end.SetSurfaceVelocity(Read(v_surface));
}

int hapticd_device_channel_limit(hapticd_device_channel* channel, double server_energy_in, const double force[3],
                                 double dt, double out[3]) {
  Vector3 f = Read(force);
  if (!f.allFinite()) f.setZero();
  const double norm = f.norm();
  if (norm > channel->max_force) f *= channel->max_force / norm;
  channel->end.ReceiveOtherIn(server_energy_in);
  const Vector3 limited = channel->end.Limit(f, dt);
  out[0] = limited.x();
  out[1] = limited.y();
  out[2] = limited.z();
  return channel->end.port().active() ? 1 : 0;
}

}  // extern "C"
