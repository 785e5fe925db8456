#pragma once

// "Model no more than a scene needs": when a client adds a mesh, find the cheapest
// representation that renders it within the scene's tolerance: a fitted sphere, box or
// capsule, else the mesh itself. A client may pin the representation instead, the convex
// hull included (never chosen by itself: the speed-accuracy chart finds the mesh cheaper
// wherever the hull is as accurate).

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "server/geometry/triangle_mesh.h"
#include "server/scene/pose.h"
#include "server/scene/shape.h"

namespace hapticd::scene {

enum class Representation { kAuto, kSphere, kBox, kCapsule, kConvex, kMesh, kCount };

// "auto", "sphere", "box", "capsule", "convex", "mesh".
std::string_view RepresentationName(Representation representation);

struct RepresentationChoice {
  Representation chosen = Representation::kAuto;  // kAuto: the object was not a mesh
  // Bound on the distance between the mesh's surface and the chosen representation's
  // surface (a two-sided Hausdorff bound, m); 0 for the mesh itself; infinite for a
  // pinned representation that the mesh is not proven to cover (open or not star-shaped
  // mesh: reason then gives the one-sided distance).
  double error_bound = 0;
  // Pose of the chosen shape in the mesh's frame (a fitted box or capsule is turned and
  // moved; identity for the hull and the mesh).
  Pose X_MS;
  // Why: e.g. "sphere fit within 3.1e-05 m <= tolerance 1e-04 m".
  std::string reason;
  // The mesh as validated (geometry::TriangleMesh): whether it bounds a solid, and how
  // many of its triangles were rewound so that its normals point out of it.
  geometry::MeshClosure closure = geometry::MeshClosure::kOpen;
  int rewound_triangles = 0;
  // What the client should know about an accepted mesh, one sentence each: its
  // triangles were rewound; it is open (a surface: never inside, unsigned distance);
  // the pinned representation's error bound exceeds the scene's tolerance.
  std::vector<std::string> warnings;
  // Set by the scene builder: the mesh as validated, kept whatever represents it so the
  // scene can be read back and exported (the BVH shares it when the mesh represents
  // itself; a primitive or hull keeps it alive for that alone), and the representation
  // the client pinned (kAuto: chosen here).
  std::shared_ptr<const geometry::TriangleMesh> mesh;
  Representation pin = Representation::kAuto;
};

struct RepresentedMesh {
  Shape shape;                  // in the frame S = X_MS applied to the mesh frame M
  RepresentationChoice choice;
};

// Chooses and builds the representation of mesh (vertices in M). tolerance > 0 (m).
// pin: kAuto to choose the cheapest of a fitted sphere, box or capsule within tolerance,
// else the mesh (the rule bench/results/speed_accuracy.md measured: a primitive where the
// surface is one, the mesh otherwise; its convex hull is never cheaper at equal error);
// or the representation to use whatever its finite error (kConvex of a non-convex mesh
// is allowed and reports its error; kSphere/kBox/kCapsule fit anyway), with a warning
// naming the bound and the tolerance when the bound exceeds it. A hull's bound is always
// finite; a primitive's is infinite where the mesh is not proven to cover it (an open or
// non-star-shaped mesh), and such a pin is refused.
// An open mesh is a surface (geometry::TriangleMesh): never inside anything, so only the
// mesh itself represents it unless pinned.
// Allocates and may take a while (hull, BVH): call it off the real-time thread.
// Throws std::invalid_argument naming the problem when pin is impossible (e.g. kConvex
// of a flat mesh) or its error has no finite bound.
RepresentedMesh ChooseMeshRepresentation(std::shared_ptr<const geometry::TriangleMesh> mesh,
                                         double tolerance, Representation pin = Representation::kAuto);

}  // namespace hapticd::scene
