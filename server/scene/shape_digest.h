#pragma once

// A 64-bit digest of an object's shape, so that a reader caching its geometry (a viewer
// holding a mesh's triangles) can tell whether an update changed it without reading it
// again. FNV-1a over the shape's kind and the bits of its parameters, a hull's vertices
// and, for an object given as a mesh, the validated mesh's vertices and triangles and
// the pinned representation. Not cryptographic: it tells honest edits apart.

#include <cstdint>

#include "server/scene/mesh_representation.h"
#include "server/scene/shape.h"

namespace hapticd::scene {

// Equal for equal shapes (bit for bit); a different shape gets a different digest but
// for a chance of about 2^-64. O(size of the shape); call it when the object is made.
uint64_t DigestShape(const Shape& shape, const RepresentationChoice& representation);

}  // namespace hapticd::scene
