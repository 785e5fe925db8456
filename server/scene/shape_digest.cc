#include "server/scene/shape_digest.h"

#include <cstring>
#include <type_traits>
#include <variant>

namespace hapticd::scene {
namespace {

// FNV-1a, 64-bit (Fowler, Noll, Vo).
class Fnv1a {
 public:
  void Bytes(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      hash_ = (hash_ ^ bytes[i]) * 0x100000001b3ull;
    }
  }
  template <typename T>
  void Value(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    Bytes(&value, sizeof value);
  }
  void Vector(const Vector3& v) {
    for (int k = 0; k < 3; ++k) Value(v[k]);
  }
  uint64_t hash() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ull;
};

}  // namespace

uint64_t DigestShape(const Shape& shape, const RepresentationChoice& representation) {
  Fnv1a digest;
  digest.Value(shape.index());
  std::visit(
      [&](const auto& s) {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, SphereShape>) {
          digest.Value(s.radius);
        } else if constexpr (std::is_same_v<S, BoxShape>) {
          digest.Vector(s.half_extents);
        } else if constexpr (std::is_same_v<S, CapsuleShape>) {
          digest.Value(s.radius);
          digest.Value(s.half_length);
        } else if constexpr (std::is_same_v<S, ConvexShape>) {
          for (const Vector3& v : s.hull->vertices) digest.Vector(v);
        }
        // a plane has no parameters; a mesh's are below, with the given mesh
      },
      shape);
  // an object given as a mesh: the mesh itself, its pin, where its representation sits
  if (const auto& mesh = representation.mesh) {
    digest.Value(static_cast<int>(representation.pin));
    digest.Value(mesh->num_vertices());
    for (const Vector3& v : mesh->vertices()) digest.Vector(v);
    for (const auto& t : mesh->triangles()) digest.Value(t);
    digest.Vector(representation.X_MS.translation);
    for (int k = 0; k < 9; ++k) digest.Value(representation.X_MS.rotation.data()[k]);
  }
  return digest.hash();
}

}  // namespace hapticd::scene
