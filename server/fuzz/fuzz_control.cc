// The control channel as a client drives it: the frame reader (control_frame.h, framed
// the way control_server.cc reads a connection) and ControlService::Handle on each
// request, over a stream of bytes that stands for one connection.
//
// Each input is served twice, on a fresh service each time: once as a loopback
// connection (authenticated from the start) and once as a remote one (a Hello with the
// token first). Checks:
//   - every frame gets exactly one reply, with its request's id (0 when the frame is not
//     a Request), and the reply has a body; an error has a known code other than
//     CODE_INTERNAL (an exception the service did not expect) and a message;
//   - a remote connection gets nothing but errors until a Hello is answered (mostly
//     CODE_UNAUTHENTICATED; a request with fields hapticd.v1 does not define is refused
//     as a bad request first);
//   - an edit's Done carries the published scene version, which only grows;
//   - answers keep their documented shape (ray hits within max_distance, one entry per
//     ray in a batch, contact depths >= 0);
//   - the reply frames (EncodeFrame) announce their length and parse back to the reply.
// A frame that announces more than kMaxFrameSize ends the connection after its error,
// and so does a frame cut short by the end of the input (the peer left mid-frame).

#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>

#include "hapticd/v1/hapticd.pb.h"
#include "server/fuzz/fuzz_check.h"
#include "server/net/test/net_harness.h"
#include "server/net/control_frame.h"
#include "server/net/control_service.h"
#include "server/net/log.h"
#include "server/net/realtime_channel.h"
#include "server/net/session_table.h"

namespace hapticd::fuzz {
namespace {

namespace v1 = ::hapticd::v1;
using net::kFrameHeaderSize;
using net::kMaxFrameSize;

constexpr char kToken[] = "0123456789abcdef-token";  // the seeds' Hello carries it

// The scene of the control service tests (net_harness.h's): a 0.1 m cube at the
// origin, a floor plane at z = -1.
using net::testing::MakeTestScene;

// A service without sockets or realtime thread: what control_server.cc holds per server.
struct Service {
  Service()
      : publisher(MakeTestScene().Build(1), 2),
        sessions(4),
        service(MakeTestScene(), publisher, sessions, counters, Options()) {}

  static net::ServiceOptions Options() {
    net::ServiceOptions options;
    options.udp_endpoint = "127.0.0.1:7460";
    options.access_token = kToken;
    return options;
  }

  scene::SnapshotPublisher publisher;
  net::SessionTable sessions;
  net::RealtimeCounters counters;
  net::ControlService service;
};

// The reply as the server writes it: a frame that announces its length and parses back.
void CheckReplyFrame(const v1::Reply& reply) {
  const std::string frame = net::EncodeFrame(reply);
  FUZZ_CHECK(frame.size() >= kFrameHeaderSize, "a reply frame has no header");
  std::array<uint8_t, kFrameHeaderSize> header;
  for (std::size_t i = 0; i < kFrameHeaderSize; ++i) header[i] = static_cast<uint8_t>(frame[i]);
  FUZZ_CHECK(net::ReadFrameLength(header) == frame.size() - kFrameHeaderSize,
             "a reply frame announces %u bytes and holds %zu", net::ReadFrameLength(header),
             frame.size() - kFrameHeaderSize);
  v1::Reply again;
  FUZZ_CHECK(again.ParseFromArray(frame.data() + kFrameHeaderSize, static_cast<int>(frame.size() - kFrameHeaderSize)),
             "a reply frame does not parse back");
  FUZZ_CHECK(again.SerializeAsString() == reply.SerializeAsString(), "a reply frame parses back to another reply");
}

void CheckError(const v1::Reply& reply) {
  const v1::Error& error = reply.error();
  FUZZ_CHECK(v1::Error::Code_IsValid(error.code()) && error.code() != v1::Error::CODE_UNSPECIFIED &&
                 error.code() != v1::Error::CODE_INTERNAL,
             "error code %d: %s", static_cast<int>(error.code()), error.message().c_str());
  FUZZ_CHECK(!error.message().empty(), "an error reply (code %d) without a message", static_cast<int>(error.code()));
}

// What a successful answer promises about its fields.
void CheckAnswer(const v1::Request& request, const v1::Reply& reply, uint64_t& scene_version,
                 const Service& service) {
  switch (reply.body_case()) {
    case v1::Reply::kDone: {
      const uint64_t version = reply.done().scene_version();
      FUZZ_CHECK(version >= scene_version, "scene version went from %llu to %llu",
                 static_cast<unsigned long long>(scene_version), static_cast<unsigned long long>(version));
      FUZZ_CHECK(version == service.publisher.current()->version(), "Done names version %llu; %llu is published",
                 static_cast<unsigned long long>(version),
                 static_cast<unsigned long long>(service.publisher.current()->version()));
      scene_version = version;
      break;
    }
    case v1::Reply::kRayHit: {
      const v1::RayHit& hit = reply.ray_hit();
      if (hit.hit()) {
        FUZZ_CHECK(hit.distance() >= 0 && hit.distance() <= request.ray_cast().max_distance(),
                   "a ray hit at %g of max_distance %g", hit.distance(), request.ray_cast().max_distance());
      }
      break;
    }
    case v1::Reply::kRayHits: {
      const v1::RayHits& hits = reply.ray_hits();
      const int n = request.ray_cast_batch().directions_size() / 3;
      FUZZ_CHECK(hits.hit_size() == n && hits.distance_size() == n && hits.objects_size() == n &&
                     hits.points_size() == 3 * n && hits.normals_size() == 3 * n,
                 "a batch of %d rays got %d hits, %d distances, %d objects, %d point and %d normal values", n,
                 hits.hit_size(), hits.distance_size(), hits.objects_size(), hits.points_size(), hits.normals_size());
      for (int i = 0; i < n; ++i) {
        const double d = hits.distance(i);
        FUZZ_CHECK(hits.hit(i) ? (d >= 0 && d <= request.ray_cast_batch().max_distance()) : d == 0,
                   "ray %d of a batch: hit %d at distance %g", i, hits.hit(i), d);
      }
      break;
    }
    case v1::Reply::kClosestPoints: {
      const v1::ClosestPoints& nearest = reply.closest_points();
      const int n = request.closest_point_batch().points_size() / 3;
      FUZZ_CHECK(nearest.found_size() == n && nearest.signed_distance_size() == n && nearest.objects_size() == n &&
                     nearest.points_size() == 3 * n && nearest.normals_size() == 3 * n,
                 "a batch of %d points got %d answers", n, nearest.found_size());
      for (int i = 0; i < n; ++i) {
        FUZZ_CHECK(nearest.found(i) == (nearest.objects(i) >= 0) &&
                       (!nearest.found(i) ||
                        nearest.signed_distance(i) <= request.closest_point_batch().max_distance()),
                   "point %d of a batch: found %d, object %d, distance %g", i, nearest.found(i),
                   nearest.objects(i), nearest.signed_distance(i));
      }
      break;
    }
    case v1::Reply::kContactsBatch: {
      const v1::ContactsBatch& batch = reply.contacts_batch();
      const int n = request.find_contacts_batch().centers_size() / 3;
      int64_t total = 0;
      for (const uint32_t count : batch.counts()) total += count;
      FUZZ_CHECK(batch.counts_size() == n && total == batch.objects_size() && total == batch.depths_size() &&
                     3 * total == batch.points_size() && 3 * total == batch.normals_size(),
                 "a batch of %d centers got %d counts adding to %lld, %d objects", n, batch.counts_size(),
                 static_cast<long long>(total), batch.objects_size());
      for (const double depth : batch.depths()) FUZZ_CHECK(depth >= 0, "a batch contact of depth %g", depth);
      break;
    }
    case v1::Reply::kContacts:
      for (const v1::Contact& contact : reply.contacts().contacts()) {
        FUZZ_CHECK(contact.depth() >= 0, "a contact with %s of depth %g", contact.object().c_str(), contact.depth());
      }
      break;
    default: break;
  }
}

// Serves data as one connection; returns after the last complete frame.
void ServeConnection(std::span<const uint8_t> data, bool loopback) {
  Service service;
  net::ConnectionState connection;
  connection.authenticated = loopback;
  bool said_hello = loopback;
  uint64_t scene_version = 1;
  while (data.size() >= kFrameHeaderSize) {
    std::array<uint8_t, kFrameHeaderSize> header;
    for (std::size_t i = 0; i < kFrameHeaderSize; ++i) header[i] = data[i];
    data = data.subspan(kFrameHeaderSize);
    const uint32_t length = net::ReadFrameLength(header);
    // too large: an error reply, then the server closes
    if (length > kMaxFrameSize) {
      const v1::Reply reply = service.service.MakeError(0, v1::Error::CODE_FRAME_TOO_LARGE, "too large");
      CheckReplyFrame(reply);
      return;
    }
    // the peer left mid-frame
    if (length > data.size()) return;
    const auto body = data.first(length);
    data = data.subspan(length);

    v1::Request request;
    v1::Reply reply;
    if (!request.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
      reply = service.service.MakeError(0, v1::Error::CODE_BAD_REQUEST, "not a hapticd.v1.Request");
    } else {
      reply = service.service.Handle(request, connection);
      FUZZ_CHECK(reply.request_id() == request.request_id(), "request %llu answered as %llu",
                 static_cast<unsigned long long>(request.request_id()),
                 static_cast<unsigned long long>(reply.request_id()));
      if (!said_hello) {
        FUZZ_CHECK(request.has_hello() || reply.has_error(), "a remote connection was served before its Hello: %s",
                   reply.ShortDebugString().c_str());
        said_hello = reply.has_hello();
        FUZZ_CHECK(said_hello == connection.authenticated, "the Hello was answered but the connection is %s",
                   connection.authenticated ? "authenticated" : "not authenticated");
      }
    }
    FUZZ_CHECK(reply.body_case() != v1::Reply::BODY_NOT_SET, "a reply without a body");
    if (reply.has_error()) {
      CheckError(reply);
    } else {
      CheckAnswer(request, reply, scene_version, service);
    }
    CheckReplyFrame(reply);
    connection.subscriptions_changed = false;
  }
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  hapticd::net::SetLogLevel(hapticd::net::LogLevel::kError);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  hapticd::fuzz::ServeConnection({data, size}, /*loopback=*/true);
  hapticd::fuzz::ServeConnection({data, size}, /*loopback=*/false);
  return 0;
}
