#include "clients/cpp/c_api/local_model_c_api.h"

#include <cstdio>
#include <exception>
#include <span>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/model_codec.h"
#include "server/net/proto_convert.h"
#include "server/remote/local_model.h"

struct hapticd_local_renderer {
  hapticd::remote::LocalRenderer renderer;
};

namespace {

void WriteError(char* error, size_t error_size, const char* message) {
  if (error != nullptr && error_size > 0) std::snprintf(error, error_size, "%s", message);
}

hapticd::geometry::Vector3 Read(const double v[3]) { return {v[0], v[1], v[2]}; }

void Write(const hapticd::geometry::Vector3& v, double out[3]) {
  out[0] = v.x();
  out[1] = v.y();
  out[2] = v.z();
}

}  // namespace

extern "C" {

hapticd_local_renderer* hapticd_local_renderer_new(const uint8_t* open_session, size_t size, char* error,
                                                   size_t error_size) {
  try {
    hapticd::v1::OpenSession open;
    if (!open.ParseFromArray(open_session, static_cast<int>(size))) {
      WriteError(error, error_size, "open_session does not parse as a hapticd.v1.OpenSession");
      return nullptr;
    }
    hapticd::geometry::Vector3 start_W;
    double timeout_s = 0;
    const hapticd::force::SessionSettings settings = hapticd::net::ReadSessionRequest(open, start_W, timeout_s);
    if (settings.device.mode != hapticd::force::DeviceMode::kImpedance) {
      WriteError(error, error_size, "open_session.device_type is admittance; a local model is for impedance devices");
      return nullptr;
    }
    auto* renderer = new hapticd_local_renderer{hapticd::remote::LocalRenderer(settings)};
    renderer->renderer.Reset(start_W);
    return renderer;
  } catch (const std::exception& e) {
    WriteError(error, error_size, e.what());
    return nullptr;
  }
}

void hapticd_local_renderer_free(hapticd_local_renderer* renderer) { delete renderer; }

int hapticd_local_renderer_accept(hapticd_local_renderer* renderer, const uint8_t* model, size_t size, double now_s,
                                  char* error, size_t error_size) {
  try {
    const hapticd::remote::LocalModel decoded = hapticd::net::DecodeLocalModel(std::span<const uint8_t>(model, size));
    return renderer->renderer.Accept(decoded, now_s) ? 1 : 0;
  } catch (const std::exception& e) {
    WriteError(error, error_size, e.what());
    return -1;
  }
}

void hapticd_local_renderer_tick(hapticd_local_renderer* renderer, const double p[3], const double v[3],
                                 const double f_held[3], double dt, double force[3], double avatar[3], int* contact,
                                 double v_surface[3]) {
  hapticd::force::DeviceInput input;
  input.p_WD = Read(p);
  input.v_WD = Read(v);
  input.f_held_W = Read(f_held);
  const hapticd::force::TickOutput output = renderer->renderer.Tick(input, dt);
  Write(output.f_W, force);
  Write(output.avatar_W, avatar);
  *contact = output.contact ? 1 : 0;
  Write(output.v_surface_W, v_surface);
}

uint64_t hapticd_local_renderer_version(const hapticd_local_renderer* renderer) {
  return renderer->renderer.model_version();
}

int hapticd_local_renderer_covers(const hapticd_local_renderer* renderer, const double p[3]) {
  return renderer->renderer.Covers(Read(p)) ? 1 : 0;
}

}  // extern "C"
