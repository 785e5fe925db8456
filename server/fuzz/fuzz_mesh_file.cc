// The mesh file readers (server/scene/mesh_file.h): every input is read as an OBJ and as
// an STL (binary when its size matches its header's triangle count, else ASCII).
//
// Checks: a refusal is a MeshFileError whose message starts with the file's name; a
// mesh read has triangles, finite vertices and indices within them; an STL's vertices
// are all at distinct positions (equal ones are merged). Any other exception escapes
// and is reported as a crash.

#include <set>
#include <string>
#include <string_view>
#include <tuple>

#include "server/fuzz/fuzz_check.h"
#include "server/scene/mesh_file.h"

namespace hapticd::fuzz {
namespace {

using scene::MeshData;
using scene::MeshFileError;

void CheckMesh(const MeshData& mesh, const char* name) {
  FUZZ_CHECK(!mesh.triangles.empty(), "%s: read without triangles", name);
  for (const auto& v : mesh.vertices) FUZZ_CHECK(v.allFinite(), "%s: a vertex is not finite", name);
  const int n = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    for (int i : t) FUZZ_CHECK(i >= 0 && i < n, "%s: a triangle names vertex %d of %d", name, i, n);
  }
}

void CheckError(const MeshFileError& error, std::string_view name) {
  const std::string_view message = error.what();
  FUZZ_CHECK(message.starts_with(name), "a mesh file error does not name the file: %s", error.what());
}

}  // namespace
}  // namespace hapticd::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace hapticd;
  using fuzz::CheckError;
  using fuzz::CheckMesh;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    CheckMesh(scene::ParseObj(bytes, "fuzz.obj"), "fuzz.obj");
  } catch (const scene::MeshFileError& error) {
    CheckError(error, "fuzz.obj");
  }
  try {
    const scene::MeshData stl = scene::ParseStl(bytes, "fuzz.stl");
    CheckMesh(stl, "fuzz.stl");
    std::set<std::tuple<double, double, double>> positions;
    for (const auto& v : stl.vertices) positions.emplace(v.x(), v.y(), v.z());
    FUZZ_CHECK(positions.size() == stl.vertices.size(), "fuzz.stl: %zu vertices at %zu positions", stl.vertices.size(),
               positions.size());
  } catch (const scene::MeshFileError& error) {
    CheckError(error, "fuzz.stl");
  }
  return 0;
}
