#include "server/conformance/query_runner.h"

#include <gtest/gtest.h>
#include <rapidjson/document.h>

#include <string>

namespace hapticd::conformance {
namespace {

// Parses an answer line; fails the test when it is not a JSON object.
rapidjson::Document Parse(const std::string& line) {
  rapidjson::Document doc;
  doc.Parse(line.c_str());
  EXPECT_FALSE(doc.HasParseError()) << line;
  EXPECT_TRUE(doc.IsObject()) << line;
  return doc;
}

std::string ErrorOf(const std::string& line) {
  const rapidjson::Document doc = Parse(AnswerCaseLine(line));
  if (!doc.HasMember("error") || !doc["error"].IsString()) return "<no error>";
  return doc["error"].GetString();
}

TEST(QueryRunner, AnswersARayTriangleHitWithItsId) {
  const rapidjson::Document doc = Parse(AnswerCaseLine(
      R"({"id": "rt-1", "op": "ray_triangle", "args": {"origin": [0.25, 0.25, 1], )"
      R"("dir": [0, 0, -2], "tri": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}})"));
  ASSERT_TRUE(doc.HasMember("result"));
  EXPECT_STREQ(doc["id"].GetString(), "rt-1");
  EXPECT_TRUE(doc["result"]["hit"].GetBool());
  EXPECT_DOUBLE_EQ(doc["result"]["t"].GetDouble(), 0.5);
  EXPECT_DOUBLE_EQ(doc["result"]["u"].GetDouble(), 0.25);
  EXPECT_DOUBLE_EQ(doc["result"]["v"].GetDouble(), 0.25);
}

TEST(QueryRunner, KeepsNumericIdsAsTheyAre) {
  const rapidjson::Document doc = Parse(AnswerCaseLine(
      R"({"id": 7, "op": "aabb_aabb", "args": {"a": {"min": [0,0,0], "max": [1,1,1]}, )"
      R"("b": {"min": [1,1,1], "max": [2,2,2]}}})"));
  EXPECT_EQ(doc["id"].GetInt(), 7);
  EXPECT_TRUE(doc["result"]["intersect"].GetBool());
}

TEST(QueryRunner, MalformedJsonGetsAnErrorWithNullId) {
  const rapidjson::Document doc = Parse(AnswerCaseLine(R"({"id": "x", "op": )"));
  EXPECT_TRUE(doc["id"].IsNull());
  EXPECT_NE(std::string(doc["error"].GetString()).find("malformed JSON"), std::string::npos);
}

TEST(QueryRunner, NonObjectCasesAreRefused) {
  EXPECT_EQ(ErrorOf("[1, 2, 3]"), "a case must be a JSON object");
  EXPECT_EQ(ErrorOf("42"), "a case must be a JSON object");
}

TEST(QueryRunner, NamesTheNonFiniteValue) {
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "ray_triangle", "args": {"origin": [0, NaN, 1], )"
                    R"("dir": [0, 0, -1], "tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.origin[1] is NaN");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "sphere_sphere", "args": {"a": {"center": [0,0,0], )"
                    R"("radius": -Infinity}, "b": {"center": [0,0,0], "radius": 1}}})"),
            "args.a.radius is -Infinity");
}

// A number is the double it spells: RapidJSON 1.1.0's full-precision parse read the
// center's 0.0e50 as 4.06e31 (server/json/exact_json.h).
TEST(QueryRunner, ReadsZerosWithExponentsAsZero) {
  const std::string b = R"(}, "b": {"center": [0, 0, 3], "radius": 1}}})";
  const std::string zero = AnswerCaseLine(
      R"({"id": "z", "op": "sphere_sphere", "args": {"a": {"center": [0.0e50, 0e80, -0e-400], "radius": 1)" + b);
  const std::string plain =
      AnswerCaseLine(R"({"id": "z", "op": "sphere_sphere", "args": {"a": {"center": [0, 0, 0], "radius": 1)" + b);
  EXPECT_EQ(zero, plain);
  EXPECT_TRUE(Parse(zero).HasMember("result")) << zero;
}

// Past the largest double is malformed, like 1e400, at the number (RapidJSON 1.1.0 read
// 9e308 as -2.8e-308); NaN and the infinities stay tokens the runner names.
TEST(QueryRunner, RefusesNumbersPastTheLargestDouble) {
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "sphere_sphere", "args": {"a": {"center": [0,0,0], "radius": 9e308}}})"),
            "malformed JSON at offset 79: Number too big to be stored in double.");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "sphere_sphere", "args": {"a": {"center": [0,0,0], "radius": 1e400}}})"),
            "malformed JSON at offset 79: Number too big to be stored in double.");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "sphere_sphere", "args": {"a": {"center": [0,0,0], "radius": NaN.5}}})"),
            "malformed JSON at offset 79: Invalid value.");
}

TEST(QueryRunner, NamesEachKindOfInvalidArgument) {
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "ray_triangle", "args": {"origin": [0, 0, 1], )"
                    R"("dir": [0, 0, 0], "tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.dir is the zero vector");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "segment_triangle", "args": {"p": [0, 0, 1], )"
                    R"("q": [0, 0, 1], "tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.p equals args.q: the segment has zero length");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "triangle_triangle", "args": {)"
                    R"("a": [[0,0,0],[1,1,1],[2,2,2]], "b": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.a is degenerate: its corners are collinear or coincide");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "sphere_sphere", "args": {"a": {"center": [0,0,0], )"
                    R"("radius": -1}, "b": {"center": [0,0,0], "radius": 1}}})"),
            "args.a.radius = -1 is negative");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "convex_convex", "args": {"a": {"points": []}, )"
                    R"("b": {"points": [[0,0,0]]}}})"),
            "args.a.points is empty");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "aabb_aabb", "args": {"a": {"min": [0,2,0], )"
                    R"("max": [1,1,1]}, "b": {"min": [0,0,0], "max": [1,1,1]}}})"),
            "args.a.min[1] = 2 exceeds args.a.max[1] = 1");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "obb_obb", "args": {"a": {"center": [0,0,0], )"
                    R"("rotation": [[1,0,0],[0,2,0],[0,0,1]], "half_extents": [1,1,1]}, )"
                    R"("b": {"center": [0,0,0], "rotation": [[1,0,0],[0,1,0],[0,0,1]], )"
                    R"("half_extents": [1,1,1]}}})"),
            "args.a.rotation is not a rotation: its columns are off orthonormal by 3");
}

TEST(QueryRunner, NamesMissingAndMistypedFields) {
  EXPECT_EQ(ErrorOf(R"({"id": "a", "args": {}})"), "case.op is missing");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": 3, "args": {}})"), "case.op must be a string");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "teleport", "args": {}})"), "unknown op \"teleport\"");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "ray_triangle", "args": {"origin": [0, 0], )"
                    R"("dir": [0, 0, 1], "tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.origin must be [x, y, z]; it has 2 elements");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "ray_triangle", "args": {"origin": [0, 0, "1"], )"
                    R"("dir": [0, 0, 1], "tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.origin[2] must be a number");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "ray_triangle", "args": {"origin": [0, 0, 1], )"
                    R"("tri": [[0,0,0],[1,0,0],[0,1,0]]}})"),
            "args.dir is missing");
}

TEST(QueryRunner, NamesTheBadPartOfAMesh) {
  const std::string tail = R"(, "p": [0,0,1], "q": [0,0,-1]}})";
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "segment_mesh", "args": {"mesh": {"vertices": )"
                    R"([[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,3]]})" + tail),
            "args.mesh: triangle 0 refers to vertex 3 but the mesh has 3 vertices");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "segment_mesh", "args": {"mesh": {"vertices": )"
                    R"([[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,-1]]})" + tail),
            "args.mesh: triangle 0 refers to vertex -1 but the mesh has 3 vertices");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "segment_mesh", "args": {"mesh": {"vertices": )"
                    R"([[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,1.5]]})" + tail),
            "args.mesh.triangles[0][2] must be an integer index");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "segment_mesh", "args": {"mesh": {"vertices": [], )"
                    R"("triangles": []})" + tail),
            "args.mesh: mesh is empty: it has 0 vertices and 0 triangles");
  EXPECT_EQ(ErrorOf(R"({"id": "a", "op": "point_inside_mesh", "args": {"mesh": {"vertices": )"
                    R"([[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}, "point": [0,0,1]}})"),
            "args.mesh is not closed: some edge is not shared by exactly two consistently "
            "oriented triangles, so it has no inside");
}

TEST(QueryRunner, AnswersAFirstMeshHitWithTheOriginalTriangleIndex) {
  // triangle 0 has zero area and is skipped; the segment crosses triangle 1 at t = 0.25
  const rapidjson::Document doc = Parse(AnswerCaseLine(
      R"({"id": "m", "op": "segment_mesh", "args": {"mesh": {"vertices": )"
      R"([[0,0,0],[1,0,0],[0,1,0],[2,0,0]], "triangles": [[0,1,3],[0,1,2]]}, )"
      R"("p": [0.25,0.25,0.5], "q": [0.25,0.25,-1.5]}})"));
  ASSERT_TRUE(doc.HasMember("result"));
  EXPECT_TRUE(doc["result"]["hit"].GetBool());
  EXPECT_DOUBLE_EQ(doc["result"]["t"].GetDouble(), 0.25);
  EXPECT_EQ(doc["result"]["triangle"].GetInt(), 1);
}

}  // namespace
}  // namespace hapticd::conformance
