#pragma once
// A server without its app: scene publisher, session table, realtime channel on a
// loopback port and the control service, plus a device socket, for the net tests.
#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <optional>
#include <string>
#include <vector>

#include "server/geometry/triangle_mesh.h"
#include "server/net/control_service.h"
#include "server/net/realtime_channel.h"

namespace hapticd::net::testing {

// A 0.1 m cube of stiffness 1000 N/m centred at the origin, and a floor plane at z = -1.
inline scene::SceneBuilder MakeTestScene() {
  scene::SceneBuilder builder;
  scene::ObjectSpec box;
  box.name = "box";
  box.shape = scene::BoxShape{geometry::Vector3(0.05, 0.05, 0.05)};
  box.material.stiffness = 1000;
  builder.Add(box);
  scene::ObjectSpec floor;
  floor.name = "floor";
  floor.shape = scene::PlaneShape{};
  floor.X_WB.translation = {0, 0, -1};
  floor.material.stiffness = 500;
  builder.Add(floor);
  return builder;
}

// An AddObject's object: mesh at x on the x axis, stiffness 1000 N/m, kept in the given
// representation and answered by the given backend.
inline v1::Object MeshObject(const std::string& name, const geometry::TriangleMesh& mesh, double x,
                             v1::Representation representation, v1::RayBackend backend = v1::RAY_BACKEND_DEFAULT) {
  v1::Object object;
  object.set_name(name);
  object.mutable_material()->set_stiffness(1000);
  object.mutable_pose()->mutable_position()->set_x(x);
  object.set_ray_backend(backend);
  v1::Mesh* out = object.mutable_shape()->mutable_mesh();
  out->set_representation(representation);
  for (const auto& v : mesh.vertices()) {
    for (int k = 0; k < 3; ++k) out->add_vertices(v[k]);
  }
  for (const auto& t : mesh.triangles()) {
    for (int k = 0; k < 3; ++k) out->add_triangles(t[k]);
  }
  return object;
}

struct Harness {
  explicit Harness(int capacity = 8, int64_t max_request_work = kDefaultMaxRequestWork)
      : publisher(MakeTestScene().Build(1), 2),
        sessions(capacity),
        realtime(asio::ip::udp::endpoint(asio::ip::make_address("127.0.0.1"), 0), sessions, publisher),
        service(MakeTestScene(), publisher, sessions, realtime.counters(), Options(max_request_work)) {
    connection.authenticated = true;
    connection.id = 1;
  }

  ServiceOptions Options(int64_t max_request_work = kDefaultMaxRequestWork) {
    ServiceOptions options;
    options.udp_endpoint = "127.0.0.1:" + std::to_string(realtime.local_endpoint().port());
    options.access_token = "0123456789abcdef-token";
    options.max_request_work = max_request_work;
    return options;
  }

  v1::Reply Call(v1::Request request) { return service.Handle(request, connection); }

  scene::SnapshotPublisher publisher;
  SessionTable sessions;
  RealtimeChannel realtime;
  ControlService service;
  ConnectionState connection;
};

// One device's UDP socket on loopback.
class DeviceSocket {
 public:
  explicit DeviceSocket(uint16_t server_port) {
    fd_ = socket(AF_INET, SOCK_DGRAM, 0);
    server_.sin_family = AF_INET;
    server_.sin_port = htons(server_port);
    server_.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  }
  ~DeviceSocket() { close(fd_); }

  void SendRaw(std::span<const uint8_t> bytes) {
    sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&server_), sizeof server_);
  }

  int fd() const { return fd_; }

  // The next datagram within timeout_ms, or nullopt.
  std::optional<std::vector<uint8_t>> Receive(int timeout_ms) {
    pollfd waiter{fd_, POLLIN, 0};
    if (poll(&waiter, 1, timeout_ms) <= 0) return std::nullopt;
    std::vector<uint8_t> bytes(2048);
    const ssize_t n = recv(fd_, bytes.data(), bytes.size(), 0);
    if (n < 0) return std::nullopt;
    bytes.resize(n);
    return bytes;
  }

 private:
  int fd_;
  sockaddr_in server_{};
};

}  // namespace hapticd::net::testing
