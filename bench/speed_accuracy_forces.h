#pragma once

// The force an avatar feels pressed into a surface, against the analytic ideal k d n
// (stiffness k, depth d, outward normal n at the pressed point), through a full
// RenderSession tick: a point avatar with the god-object method, and a sphere avatar of
// 5 mm with the finger proxy.
//
// Per contact site: the session is reset with the avatar 5 mm off the surface, the
// device is held d deep (the point d below the surface; the sphere's centre so that the
// ball reaches d below it) and ticked settle_ticks times; the last force is compared
// with k d n (error |f - k d n|, N). Then timed_ticks more ticks are timed one site at a
// time (steady state: the proxy resting on the surface, the device still), and the
// per-tick time is the median over repetitions of the whole set of sites.

#include <string>
#include <vector>

#include "bench/speed_accuracy_io.h"
#include "bench/speed_accuracy_surfaces.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::bench {

struct ForceOptions {
  double stiffness = 2000;      // N/m, the object's material
  double avatar_radius = 0.005;  // m, the sphere avatar
  int settle_ticks = 20;
  int timed_ticks = 16;
};

// Two rows (force_point, force_sphere) for the scene's single object, which must sit at
// the origin, have stiffness options.stiffness and no damping or friction (the ideal
// force is then k d n). identity gives surface, representation, level, triangles and
// backend.
std::vector<ResultRow> MeasureForces(const scene::SceneSnapshot& scene, const QueryInputs& inputs,
                                     const ForceOptions& options, const TimingOptions& timing,
                                     const ResultRow& identity);

}  // namespace hapticd::bench
