#pragma once

// Internal: what an Embree callback does once the tick's work budget
// (geometry::WorkMeter) is spent. Each call charges one unit; past the budget the query
// is cut short, its answer incomplete (the metered caller throws it away).

#include <embree3/rtcore.h>

#include <limits>

#include "server/geometry/work_meter.h"

namespace hapticd::embree::internal {

// Point queries: shrinks the query to its point; returns true (the radius changed)
// when the budget is spent, for the callback to return at once.
inline bool ShrinkWhenOverBudget(RTCPointQueryFunctionArguments* args) {
  if (geometry::WorkMeter::Charge(1)) return false;
  args->query->radius = 0;
  return true;
}

// Ray packets (RTCRayN of n lanes): ends every valid lane's traversal when the budget is
// spent; returns whether it did.
inline bool EndWhenOverBudget(RTCRayN* rays, unsigned n, const int* valid) {
  if (geometry::WorkMeter::Charge(1)) return false;
  for (unsigned i = 0; i < n; ++i) {
    if (valid[i] != 0) RTCRayN_tfar(rays, n, i) = -std::numeric_limits<float>::infinity();
  }
  return true;
}

}  // namespace hapticd::embree::internal
