#pragma once

// Reading triangle meshes from files: Wavefront OBJ and STL (ASCII and binary). The
// readers only parse; they do not validate the mesh as a solid (geometry::TriangleMesh
// and the scene builder do). Every error names the file and where in it: the line for
// text files ("part.obj:12: ..."), the byte offset for binary STL.

#include <array>
#include <filesystem>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::scene {

// A file that cannot be read or parsed.
class MeshFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Vertices (in the file's frame and units) and triangles as vertex index triples, in the
// file's winding order.
struct MeshData {
  std::vector<geometry::Vector3> vertices;
  std::vector<std::array<int, 3>> triangles;
};

// Reads path by its extension: .obj, or .stl (either kind), case-insensitive. Throws
// MeshFileError naming the file when it is missing or unreadable, has another extension,
// or does not parse; a file without triangles is refused.
MeshData ReadMeshFile(const std::filesystem::path& path);

// OBJ: `v x y z [w]` (also `v x y z r g b`) and `f` statements with 1-based or negative
// (relative) indices in any of the forms i, i/t, i//n, i/t/n; polygons are fanned into
// triangles. Other statements (vt, vn, o, g, s, usemtl, ...) are ignored. name labels
// errors ("name:LINE: ...").
MeshData ParseObj(std::string_view text, std::string_view name);

// STL, binary when the size matches 84 + 50 x the triangle count in its header, else
// ASCII (`solid ... facet normal ... outer loop vertex x y z (x3) endloop endfacet ...`).
// Triangles keep their vertex order; vertices at exactly equal positions are merged into
// one, so that a closed STL becomes a closed indexed mesh. Facet normals are ignored.
MeshData ParseStl(std::string_view bytes, std::string_view name);

}  // namespace hapticd::scene
