#include "server/scene/mesh_file.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>

#include "server/geometry/triangle_mesh.h"

namespace hapticd::scene {
namespace {

using geometry::Vector3;
using Triangles = std::vector<std::array<int, 3>>;

// The message of the MeshFileError that parse() throws; fails the test when none is.
template <typename Parse>
std::string ErrorOf(Parse parse) {
  try {
    parse();
  } catch (const MeshFileError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no MeshFileError";
  return "";
}

// A unit cube [0,1]^3 with outward-wound quads, in OBJ.
constexpr std::string_view kCubeObj = R"(# a cube
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
)";

// A tetrahedron's four outward faces, as corner positions.
std::vector<std::array<Vector3, 3>> TetrahedronFacets() {
  const Vector3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
  return {{a, c, b}, {a, b, d}, {a, d, c}, {b, c, d}};
}

std::string AsciiStl(const std::vector<std::array<Vector3, 3>>& facets) {
  std::string text = "solid tetra made by hand\r\n";
  for (const auto& facet : facets) {
    text += "  facet normal 0 0 0\r\n    outer loop\r\n";
    for (const Vector3& p : facet) text += "      vertex " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\r\n";
    text += "    endloop\r\n  endfacet\r\n";
  }
  return text + "endsolid tetra\r\n";
}

void AppendUint32Le(std::string& bytes, uint32_t value) {
  for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

// Binary STL whose 80-byte header starts with "solid" (as some exporters write it).
std::string BinaryStl(const std::vector<std::array<Vector3, 3>>& facets) {
  std::string bytes = "solid but binary";
  bytes.resize(80, ' ');
  AppendUint32Le(bytes, static_cast<uint32_t>(facets.size()));
  for (const auto& facet : facets) {
    for (int i = 0; i < 3; ++i) AppendUint32Le(bytes, std::bit_cast<uint32_t>(0.0f));
    for (const Vector3& p : facet) {
      for (int i = 0; i < 3; ++i) AppendUint32Le(bytes, std::bit_cast<uint32_t>(static_cast<float>(p[i])));
    }
    bytes += std::string(2, '\0');
  }
  return bytes;
}

TEST(ParseObj, CubeQuadsAreFannedIntoAClosedOutwardMesh) {
  const MeshData data = ParseObj(kCubeObj, "cube.obj");
  ASSERT_EQ(data.vertices.size(), 8u);
  ASSERT_EQ(data.triangles.size(), 12u);
  EXPECT_EQ(data.vertices[6], Vector3(1, 1, 1));
  // "f 1 4 3 2" fans around its first corner: (1 4 3), (1 3 2), 0-based
  EXPECT_EQ(data.triangles[0], (std::array<int, 3>{0, 3, 2}));
  EXPECT_EQ(data.triangles[1], (std::array<int, 3>{0, 2, 1}));
  const geometry::TriangleMesh mesh(data.vertices, data.triangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_NEAR(mesh.signed_volume(), 1.0, 1e-15);
}

TEST(ParseObj, CornerFormsNegativeIndicesCommentsAndCrLf) {
  const MeshData data = ParseObj(
      "v 0 0 0\r\nv +1 0 0 1\r\nv 0 1 0 0.5 0.5 0.5 # a coloured vertex\r\n"
      "f 1/1 2/2/2 3//3\r\nf -3 -2 -1\r\nvt 0 0\r\ns off\r\n",
      "forms.obj");
  ASSERT_EQ(data.vertices.size(), 3u);
  EXPECT_EQ(data.vertices[1], Vector3(1, 0, 0));
  EXPECT_EQ(data.triangles, (Triangles{{0, 1, 2}, {0, 1, 2}}));
}

TEST(ParseObj, PositiveIndicesMayNameLaterVertices) {
  const MeshData data = ParseObj("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "late.obj");
  EXPECT_EQ(data.triangles, (Triangles{{0, 1, 2}}));
}

TEST(ParseObj, ErrorsNameTheFileAndLine) {
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n", "m.obj"); }),
            "m.obj:5: face index 9 refers to vertex 9, but the file has 3 vertices");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "m.obj"); }),
            "m.obj:4: face index 0 is invalid (OBJ indices start at 1)");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", "m.obj"); }),
            "m.obj:3: face index -3 reaches 3 vertices back, but only 2 are defined before this line");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 zero 0\n", "m.obj"); }), "m.obj:1: 'zero' is not a number");
  EXPECT_EQ(ErrorOf([] { ParseObj("# x\nv 0 nan 0\n", "m.obj"); }),
            "m.obj:2: coordinate 'nan' is not a finite number");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 1e999 0\n", "m.obj"); }), "m.obj:1: '1e999' is not a number");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0\n", "m.obj"); }),
            "m.obj:1: vertex has 2 numbers; it needs x y z (optionally w, or r g b)");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nv 1 0 0\nf 1 2\n", "m.obj"); }),
            "m.obj:3: face has 2 corners; it needs at least 3");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nf a/1 1 1\n", "m.obj"); }),
            "m.obj:2: face corner 'a/1' has no valid vertex index");
  EXPECT_EQ(ErrorOf([] { ParseObj("v 0 0 0\nv 1 0 0\n", "m.obj"); }), "m.obj: has no faces (no 'f' statements)");
}

TEST(ParseStl, AsciiMergesEqualVerticesIntoAClosedMesh) {
  const MeshData data = ParseStl(AsciiStl(TetrahedronFacets()), "tetra.stl");
  ASSERT_EQ(data.vertices.size(), 4u);
  ASSERT_EQ(data.triangles.size(), 4u);
  // the first facet (a c b) keeps its winding: a=0, c=1, b=2
  EXPECT_EQ(data.triangles[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(data.vertices[1], Vector3(0, 1, 0));
  const geometry::TriangleMesh mesh(data.vertices, data.triangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_NEAR(mesh.signed_volume(), 1.0 / 6.0, 1e-15);
}

TEST(ParseStl, BinaryWithSolidHeaderReadsLikeAscii) {
  const MeshData binary = ParseStl(BinaryStl(TetrahedronFacets()), "tetra.stl");
  const MeshData ascii = ParseStl(AsciiStl(TetrahedronFacets()), "tetra.stl");
  EXPECT_EQ(binary.vertices, ascii.vertices);
  EXPECT_EQ(binary.triangles, ascii.triangles);
}

TEST(ParseStl, ErrorsNameTheFileAndLineOrOffset) {
  std::string ascii = AsciiStl(TetrahedronFacets());
  ascii.replace(ascii.find("endloop"), 7, "endlop");
  EXPECT_EQ(ErrorOf([&] { ParseStl(ascii, "t.stl"); }), "t.stl:7: expected 'endloop', found 'endlop'");
  EXPECT_EQ(ErrorOf([] { ParseStl("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n", "t.stl"); }),
            "t.stl:4: the file ends where a number was expected");
  EXPECT_EQ(ErrorOf([] { ParseStl("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 inf\n", "t.stl"); }),
            "t.stl:4: coordinate 'inf' is not a finite number");
  EXPECT_EQ(ErrorOf([] { ParseStl("solid x\nendsolid x\n", "t.stl"); }), "t.stl: has no triangles");
  EXPECT_EQ(ErrorOf([] { ParseStl("hello", "t.stl"); }),
            "t.stl: not an STL file: 5 bytes is too short for binary STL and it does not start with 'solid'");

  // a truncated binary file
  std::string binary = BinaryStl(TetrahedronFacets());
  binary[0] = 'X';
  binary.resize(binary.size() - 10);
  EXPECT_EQ(ErrorOf([&] { ParseStl(binary, "t.stl"); }),
            "t.stl: byte offset 80: binary STL header says 4 triangles, which need 284 bytes, but the file has "
            "274 (and it does not start with 'solid')");

  // a NaN coordinate: the second triangle's first vertex's y, at 84 + 50 + 12 + 4
  std::vector<std::array<Vector3, 3>> facets = TetrahedronFacets();
  facets[1][0].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ErrorOf([&] { ParseStl(BinaryStl(facets), "t.stl"); }),
            "t.stl: byte offset 150 (triangle 1): vertex coordinate nan is not finite");
}

TEST(ReadMeshFile, ReadsByExtensionAndNamesMissingFiles) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "mesh_file_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "cube.OBJ") << kCubeObj;
  std::ofstream(dir / "tetra.stl", std::ios::binary) << BinaryStl(TetrahedronFacets());
  std::ofstream(dir / "cube.ply") << "ply\n";

  EXPECT_EQ(ReadMeshFile(dir / "cube.OBJ").triangles.size(), 12u);
  EXPECT_EQ(ReadMeshFile(dir / "tetra.stl").vertices.size(), 4u);
  EXPECT_EQ(ErrorOf([&] { ReadMeshFile(dir / "none.obj"); }), (dir / "none.obj").string() + ": does not exist");
  EXPECT_EQ(ErrorOf([&] { ReadMeshFile(dir); }),
            dir.string() + ": unknown mesh file type ''; it must be .obj or .stl");
  EXPECT_EQ(ErrorOf([&] { ReadMeshFile(dir / "cube.ply"); }),
            (dir / "cube.ply").string() + ": unknown mesh file type '.ply'; it must be .obj or .stl");
  std::filesystem::create_directories(dir / "folder.obj");
  EXPECT_EQ(ErrorOf([&] { ReadMeshFile(dir / "folder.obj"); }), (dir / "folder.obj").string() + ": is not a regular file");
}

}  // namespace
}  // namespace hapticd::scene
