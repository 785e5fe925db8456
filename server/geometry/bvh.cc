#include "server/geometry/bvh.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <exception>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

namespace hapticd::geometry {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kFloatMax = std::numeric_limits<float>::max();
constexpr int kBins = 16;
// SAH cost of one traversal step, in units of one triangle test: the exact triangle
// tests cost several box tests, so leaves stay small (mostly one triangle). Measured:
// larger leaves (cost 1 or 2) make segment queries on 1M triangles 1.5x slower and
// closest-point queries 10-20% faster.
constexpr float kTraversalCost = 0.5f;
// Past this depth splits are at the object median, so the depth stays under
// kMaxBvhDepth whatever the input (at most 28 more halvings of 2^28 triangles).
constexpr int kSahDepthLimit = 32;
// Ranges smaller than this are not worth a thread.
constexpr int kParallelMinPrimitives = 4096;

// Four floats in one SSE/NEON register (GCC/Clang vector extension); lane 3 is unused
// by the geometry.
using Float4 = float __attribute__((vector_size(16)));
using Int4 = int32_t __attribute__((vector_size(16)));

inline Float4 Min(Float4 a, Float4 b) { return a < b ? a : b; }
inline Float4 Max(Float4 a, Float4 b) { return a > b ? a : b; }
inline Float4 Splat(float x) { return Float4{x, x, x, x}; }


// A node side from a ref side: the clamped extremes stand for everything beyond.
float WidenLow(float lo) { return lo <= -kFloatMax ? -kInf : lo; }
float WidenHigh(float hi) { return hi >= kFloatMax ? kInf : hi; }

struct FloatBox {
  Float4 lo = Splat(kInf);
  Float4 hi = Splat(-kInf);

  void Extend(Float4 l, Float4 h) {
    lo = Min(lo, l);
    hi = Max(hi, h);
  }
  void Extend(const FloatBox& b) { Extend(b.lo, b.hi); }
  // Half the surface area; zero for an empty box.
  float half_area() const {
    if (lo[0] > hi[0]) return 0;
    const Float4 d = hi - lo;
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
  }
};

// One triangle's box, float rounded outwards; lane 3 of lo carries the triangle's
// original index as the bits of a normal float (offset by the bits of 1.0f: denormals
// would slow every comparison of the lane).
struct PrimRef {
  Float4 lo;
  Float4 hi;

  static constexpr int32_t kIndexBias = 0x3f800000;
  static float EncodeIndex(int index) { return std::bit_cast<float>(index + kIndexBias); }
  int index() const { return std::bit_cast<int32_t>(lo[3]) - kIndexBias; }
  // Twice the box centre on lanes 0-2 (finite or +-inf, never NaN: the sides are
  // finite).
  Float4 centroid() const { return lo + hi; }
};

// Primitives [begin, end) of the ref array with their box and centroid box.
struct Range {
  int begin = 0, end = 0;
  FloatBox box;
  FloatBox centroids;

  int size() const { return end - begin; }
  void Add(const PrimRef& r) {
    box.Extend(r.lo, r.hi);
    const Float4 c = r.centroid();
    centroids.Extend(c, c);
  }
};

// Centroid binning: bin = floor((c - base) * scale) per axis, clamped to the bins (a
// NaN from overflow lands in bin 0 instead of being undefined). Small ranges get fewer
// bins: more bins than primitives buy nothing and cost a sweep.
struct Binning {
  int num_bins = kBins;
  Float4 base = Splat(0);
  Float4 scale = Splat(0);  // zero on an axis where the centroids do not spread

  Binning() = default;
  explicit Binning(const Range& r) : num_bins(std::clamp(r.size(), 2, kBins)) {
    base = r.centroids.lo;
    for (int a = 0; a < 3; ++a) {
      const float extent = r.centroids.hi[a] - r.centroids.lo[a];
      if (extent > 0 && std::isfinite(extent)) scale[a] = num_bins * 0.99999f / extent;
    }
  }
  Int4 Bins(const PrimRef& ref) const {
    Float4 x = (ref.centroid() - base) * scale;
    const float last = static_cast<float>(num_bins - 1);
    x = x > 0 ? x : Splat(0);
    x = x < last ? x : Splat(last);
    return __builtin_convertvector(x, Int4);
  }
};

struct Split {
  int axis = -1;   // -1: no SAH split exists (all centroids coincide)
  int bin = 0;     // left side: bins < bin
  float cost = 0;  // SAH cost, in triangle tests
};

// Bin boxes and counts per axis; FillBins initialises the entries it uses.
struct Bins {
  Float4 lo[3][kBins];
  Float4 hi[3][kBins];
  int count[3][kBins];
};

// Clears the first num_bins entries per axis.
void ClearBins(const Binning& binning, Bins& bins) {
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < binning.num_bins; ++k) {
      bins.lo[a][k] = Splat(kInf);
      bins.hi[a][k] = Splat(-kInf);
      bins.count[a][k] = 0;
    }
  }
}

inline void AddToBins(const PrimRef& ref, const Binning& binning, Bins& bins) {
  const Int4 b = binning.Bins(ref);
  for (int a = 0; a < 3; ++a) {
    bins.lo[a][b[a]] = Min(bins.lo[a][b[a]], ref.lo);
    bins.hi[a][b[a]] = Max(bins.hi[a][b[a]], ref.hi);
    ++bins.count[a][b[a]];
  }
}

// Bins refs [begin, end) alternately into two bin sets, so that neighbours (which
// usually share a bin) do not wait on each other's stores.
void FillBinPair(const PrimRef* refs, int begin, int end, const Binning& binning, Bins (&bins)[2]) {
  ClearBins(binning, bins[0]);
  ClearBins(binning, bins[1]);
  int i = begin;
  for (; i + 1 < end; i += 2) {
    AddToBins(refs[i], binning, bins[0]);
    AddToBins(refs[i + 1], binning, bins[1]);
  }
  if (i < end) AddToBins(refs[i], binning, bins[0]);
}

// Adds the second set of bins into the first.
void MergeBins(const Binning& binning, const Bins& from, Bins& into) {
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < binning.num_bins; ++k) {
      into.lo[a][k] = Min(into.lo[a][k], from.lo[a][k]);
      into.hi[a][k] = Max(into.hi[a][k], from.hi[a][k]);
      into.count[a][k] += from.count[a][k];
    }
  }
}

// Binned SAH over the three axes: bin boxes and counts, then a sweep from each side.
// With a spare thread, a large range is binned in two halves at once.
Split FindSahSplit(const PrimRef* refs, const Range& r, const Binning& binning,
                   bool use_thread) {
  const int nb = binning.num_bins;
  Bins bins[2];
  if (r.size() < 64) {
    ClearBins(binning, bins[0]);
    for (int i = r.begin; i < r.end; ++i) AddToBins(refs[i], binning, bins[0]);
  } else if (use_thread && r.size() >= 2 * kParallelMinPrimitives) {
    const int mid = r.begin + r.size() / 2;
    Bins upper[2];
    std::thread worker([&] { FillBinPair(refs, mid, r.end, binning, upper); });
    FillBinPair(refs, r.begin, mid, binning, bins);
    worker.join();
    MergeBins(binning, upper[0], bins[0]);
    MergeBins(binning, upper[1], bins[0]);
    MergeBins(binning, bins[1], bins[0]);
  } else {
    FillBinPair(refs, r.begin, r.end, binning, bins);
    MergeBins(binning, bins[1], bins[0]);
  }
  const Bins& b = bins[0];

  Split best;
  float best_cost = kInf;
  for (int a = 0; a < 3; ++a) {
    if (binning.scale[a] == 0) continue;
    // right_cost[k]: area x count of bins k..nb-1
    float right_cost[kBins];
    FloatBox right;
    int right_count = 0;
    for (int k = nb - 1; k > 0; --k) {
      right.Extend(b.lo[a][k], b.hi[a][k]);
      right_count += b.count[a][k];
      right_cost[k] = right_count > 0 ? right.half_area() * right_count : kInf;
    }
    FloatBox left;
    int left_count = 0;
    for (int k = 1; k < nb; ++k) {
      left.Extend(b.lo[a][k - 1], b.hi[a][k - 1]);
      left_count += b.count[a][k - 1];
      if (left_count == 0) continue;
      const float cost = left.half_area() * left_count + right_cost[k];
      if (cost < best_cost) {
        best_cost = cost;
        best.axis = a;
        best.bin = k;
      }
    }
  }
  // both sides of zero area (flat, coincident boxes): any split is as good
  const float parent_area = r.box.half_area();
  best.cost = kTraversalCost + (parent_area > 0 ? best_cost / parent_area : 0.0f);
  return best;
}

// Reorders [begin, end) so that `goes_left` ones come first; returns both sides with
// their bounds. Hoare's two-pointer scheme, one pass.
template <typename Pred>
std::pair<Range, Range> Partition(PrimRef* refs, const Range& r, Pred goes_left) {
  Range left, right;
  int i = r.begin, j = r.end - 1;
  while (i <= j) {
    if (goes_left(refs[i])) {
      left.Add(refs[i++]);
      continue;
    }
    while (j > i && !goes_left(refs[j])) right.Add(refs[j--]);
    // refs[i] belongs right; if i == j it is the last one
    if (j == i) {
      right.Add(refs[j--]);
      break;
    }
    std::swap(refs[i], refs[j]);
    left.Add(refs[i++]);
    right.Add(refs[j--]);
  }
  left.begin = r.begin;
  left.end = i;
  right.begin = i;
  right.end = r.end;
  return {left, right};
}

// Halves [begin, end) at the median centroid along the widest centroid axis.
std::pair<Range, Range> SplitAtMedian(PrimRef* refs, const Range& r) {
  int axis = 0;
  const Float4 extent = r.centroids.hi - r.centroids.lo;
  for (int a = 1; a < 3; ++a) {
    if (extent[a] > extent[axis]) axis = a;
  }
  const int mid = r.begin + r.size() / 2;
  std::nth_element(refs + r.begin, refs + mid, refs + r.end,
                   [axis](const PrimRef& x, const PrimRef& y) {
                     return x.centroid()[axis] < y.centroid()[axis];
                   });
  Range left, right;
  left.begin = r.begin;
  left.end = right.begin = mid;
  right.end = r.end;
  for (int i = left.begin; i < left.end; ++i) left.Add(refs[i]);
  for (int i = right.begin; i < right.end; ++i) right.Add(refs[i]);
  return {left, right};
}

// Runs fn(begin, end) over [0, n) in `threads` contiguous chunks.
template <typename Fn>
void ParallelFor(int n, int threads, Fn fn) {
  threads = std::clamp(threads, 1, std::max(1, n / kParallelMinPrimitives));
  auto chunk_start = [&](int k) {
    return static_cast<int>(static_cast<long long>(n) * k / threads);
  };
  std::vector<std::thread> workers;
  // a thread that cannot start leaves its chunk to this one
  int started = 1;
  try {
    for (; started < threads; ++started) {
      workers.emplace_back(fn, chunk_start(started), chunk_start(started + 1));
    }
  } catch (const std::system_error&) {
  }
  fn(0, chunk_start(1));
  if (started < threads) fn(chunk_start(started), n);
  for (std::thread& w : workers) w.join();
}

// A range with its split decided: a leaf, or how it halves.
struct PlannedRange {
  Range range;
  int depth = 0;  // binary splits above it: what the SAH depth limit counts
  bool leaf = false;
  Binning binning;
  Split split;  // axis -1 (and not a leaf): halve at the median

  PlannedRange() = default;
  PlannedRange(const Range& r, int d) : range(r), depth(d), binning(r) {}
};

// Top-down build. Each node takes a planned range and splits it in two, then keeps
// splitting whichever of its pieces has the largest box until it has kBvhWidth of them
// or only leaves remain (as Embree builds its wide BVHs); each piece becomes a leaf or
// a child node.
class Builder {
 public:
  Builder(PrimRef* refs, const BvhBuildOptions& options) : refs_(refs), options_(options) {}

  // Decides whether r is a leaf (one triangle, or small enough that the SAH prefers
  // it) and where it would split; use_thread lets the binning take a second thread.
  PlannedRange Plan(const Range& r, int depth, bool use_thread = false) const {
    PlannedRange p(r, depth);
    const int n = r.size();
    if (n == 1) {
      p.leaf = true;
      return p;
    }
    if (depth < kSahDepthLimit) p.split = FindSahSplit(refs_, r, p.binning, use_thread);
    // no SAH split (coincident centroids, or too deep): a leaf, or halve by count
    if (n <= options_.max_leaf_size) p.leaf = p.split.axis < 0 || p.split.cost >= n;
    return p;
  }

  // Builds the subtree of a planned range into `nodes` (pre-order); returns its child
  // reference (node index, or ~first primitive for a leaf) and leaf count.
  std::pair<int32_t, int32_t> Build(const PlannedRange& planned, int node_depth,
                                    int spare_threads, std::vector<BvhNode>& nodes,
                                    int& max_depth) {
    const Range& r = planned.range;
    if (planned.leaf) return {~r.begin, r.size()};

    // split the largest-area piece until the node is full or all pieces are leaves
    PlannedRange pieces[kBvhWidth];
    pieces[0] = planned;
    int num_pieces = 1;
    while (num_pieces < kBvhWidth) {
      int widest = -1;
      for (int k = 0; k < num_pieces; ++k) {
        if (pieces[k].leaf) continue;
        const float area = pieces[k].range.box.half_area();
        if (widest < 0 || area > pieces[widest].range.box.half_area()) widest = k;
      }
      if (widest < 0) break;
      const auto [left, right] = Halve(pieces[widest]);
      const int depth = pieces[widest].depth + 1;
      for (int k = num_pieces; k > widest + 1; --k) pieces[k] = pieces[k - 1];
      // with a spare thread, the two halves are planned at once
      if (spare_threads > 0 && r.size() >= 2 * kParallelMinPrimitives) {
        std::thread worker([&, right = right] { pieces[widest + 1] = Plan(right, depth); });
        pieces[widest] = Plan(left, depth);
        worker.join();
      } else {
        pieces[widest] = Plan(left, depth);
        pieces[widest + 1] = Plan(right, depth);
      }
      ++num_pieces;
    }

    // this node, allocated before its children (pre-order); unused slots stay empty
    const int index = static_cast<int>(nodes.size());
    nodes.emplace_back();
    BvhNode& node = nodes.back();
    for (int c = 0; c < kBvhWidth; ++c) {
      for (int a = 0; a < 3; ++a) {
        node.lo[a][c] = c < num_pieces ? WidenLow(pieces[c].range.box.lo[a]) : kInf;
        node.hi[a][c] = c < num_pieces ? WidenHigh(pieces[c].range.box.hi[a]) : -kInf;
      }
      node.child[c] = ~0;
      node.count[c] = 0;
    }
    max_depth = std::max(max_depth, node_depth + 1);

    // the pieces' subtrees; with a spare thread, the later pieces (about half the
    // triangles) go to a new thread, into their own array, appended afterwards
    std::pair<int32_t, int32_t> child_refs[kBvhWidth];
    int split_at = num_pieces;
    if (spare_threads > 0 && r.size() >= 2 * kParallelMinPrimitives) {
      int before = pieces[0].range.size();
      split_at = 1;
      while (split_at < num_pieces - 1 && 2 * before < r.size()) {
        before += pieces[split_at++].range.size();
      }
    }
    const int shared = std::max(spare_threads - 1, 0);
    std::vector<BvhNode> later_nodes;
    int later_depth = 0;
    std::exception_ptr error;
    std::thread worker;
    if (split_at < num_pieces) {
      worker = std::thread([&] {
        try {
          later_nodes.reserve(r.size());
          for (int c = split_at; c < num_pieces; ++c) {
            child_refs[c] = Build(pieces[c], node_depth + 1, shared / 2, later_nodes, later_depth);
          }
        } catch (...) {
          error = std::current_exception();
        }
      });
    }
    // (the worker is joined before any error leaves this function)
    std::exception_ptr own_error;
    try {
      for (int c = 0; c < split_at; ++c) {
        child_refs[c] = Build(pieces[c], node_depth + 1, shared - shared / 2, nodes, max_depth);
      }
    } catch (...) {
      own_error = std::current_exception();
    }
    if (worker.joinable()) worker.join();
    if (own_error) std::rethrow_exception(own_error);
    if (split_at < num_pieces) {
      if (error) std::rethrow_exception(error);
      const int32_t offset = static_cast<int32_t>(nodes.size());
      for (BvhNode later : later_nodes) {
        for (int c = 0; c < kBvhWidth; ++c) later.child[c] += later.child[c] >= 0 ? offset : 0;
        nodes.push_back(later);
      }
      for (int c = split_at; c < num_pieces; ++c) {
        child_refs[c].first += child_refs[c].first >= 0 ? offset : 0;
      }
      max_depth = std::max(max_depth, later_depth);
    }
    for (int c = 0; c < num_pieces; ++c) {
      nodes[index].child[c] = child_refs[c].first;
      nodes[index].count[c] = child_refs[c].first >= 0 ? 0 : child_refs[c].second;
    }
    return {index, 0};
  }

 private:
  // The two halves of a range that is not a leaf.
  std::pair<Range, Range> Halve(const PlannedRange& p) const {
    if (p.split.axis < 0) return SplitAtMedian(refs_, p.range);
    const int axis = p.split.axis, bin = p.split.bin;
    return Partition(refs_, p.range,
                     [&](const PrimRef& ref) { return p.binning.Bins(ref)[axis] < bin; });
  }

  PrimRef* refs_;
  const BvhBuildOptions& options_;
};

// The primitives under each node, [begin, end) in leaf order: a subtree is one range,
// since the builder partitions its range in place, depth first.
struct PrimitiveRange {
  int begin = 0;
  int end = 0;
};

PrimitiveRange ChildRange(const std::vector<BvhNode>& nodes, const std::vector<PrimitiveRange>& ranges,
                          int node, int c) {
  const BvhNode& n = nodes[node];
  if (!n.is_leaf(c)) return ranges[n.child[c]];
  return {n.first_primitive(c), n.first_primitive(c) + n.count[c]};
}

void FillRanges(const std::vector<BvhNode>& nodes, int node, std::vector<PrimitiveRange>& ranges) {
  PrimitiveRange all{std::numeric_limits<int>::max(), 0};
  for (int c = 0; c < kBvhWidth; ++c) {
    if (!nodes[node].is_leaf(c)) FillRanges(nodes, nodes[node].child[c], ranges);
    const PrimitiveRange range = ChildRange(nodes, ranges, node, c);
    if (range.begin == range.end) continue;
    all.begin = std::min(all.begin, range.begin);
    all.end = std::max(all.end, range.end);
  }
  ranges[node] = all.begin < all.end ? all : PrimitiveRange{};
}

// Disc c of discs about the given triangles (left infinite where there are none or too
// many, or where float cannot hold it).
void FitDisc(std::span<const Triangle> triangles, int c, BvhDiscs& discs) {
  if (triangles.empty() || triangles.size() > kMaxDiscTriangles) return;
  // any centre and unit normal make a disc that holds them; the corners' mean and the
  // summed normal a small, thin one (for one triangle, its bounding circle about its
  // centroid: a smaller disc than about its box's middle, and the bound of
  // LowerDistanceExceeds)
  Vector3 mid = Vector3::Zero();
  Vector3 area = Vector3::Zero();
  for (const Triangle& t : triangles) {
    mid += t.v0 + t.v1 + t.v2;
    area += (t.v1 - t.v0).cross(t.v2 - t.v0);
  }
  mid /= 3.0 * static_cast<double>(triangles.size());
  const double length = area.norm();
  const Vector3 unit = length > 0 && std::isfinite(length) ? Vector3(area / length) : Vector3::UnitZ();
  // (rounded by RoundDownToFloat, not a cast: at -O3 GCC 12's SLP vectorizer kept the
  // doubles of a cast for centre_d below, so the disc missed corners by ulps of float)
  float centre[3], normal[3];
  for (int a = 0; a < 3; ++a) {
    centre[a] = RoundDownToFloat(mid[a]);
    normal[a] = RoundDownToFloat(unit[a]);
  }
  // as stored, so that the disc holds every corner with what the queries read
  const Vector3 centre_d(centre[0], centre[1], centre[2]);
  const Vector3 normal_d(normal[0], normal[1], normal[2]);
  double thickness = 0;
  double radius_squared = 0;
  for (const Triangle& t : triangles) {
    for (const Vector3* corner : {&t.v0, &t.v1, &t.v2}) {
      const Vector3 offset = *corner - centre_d;
      const double height = normal_d.dot(offset);
      thickness = std::max(thickness, std::abs(height));
      radius_squared = std::max(radius_squared, (offset - height * normal_d).squaredNorm());
    }
  }
  const float radius = RoundUpToFloat(std::sqrt(radius_squared));
  const float half = RoundUpToFloat(thickness);
  if (!std::isfinite(centre_d.sum()) || !(radius < kFloatMax) || !(half < kFloatMax)) return;
  for (int a = 0; a < 3; ++a) {
    discs.centre[a][c] = centre[a];
    discs.normal[a][c] = normal[a];
  }
  discs.radius[c] = radius;
  discs.thickness[c] = half;
}

}  // namespace

MeshBvh::MeshBvh(std::shared_ptr<const TriangleMesh> mesh, const BvhBuildOptions& options)
    : mesh_(std::move(mesh)) {
  if (mesh_ == nullptr) throw std::invalid_argument("MeshBvh needs a mesh, got null");
  if (options.max_leaf_size < 1 || options.max_leaf_size > 16 || options.num_threads < 1) {
    throw std::invalid_argument("BVH options out of range: max_leaf_size " +
                                std::to_string(options.max_leaf_size) + " (1..16), num_threads " +
                                std::to_string(options.num_threads) + " (>= 1)");
  }
  const std::vector<int>& source = mesh_->nondegenerate_triangles();
  const int n = static_cast<int>(source.size());
  const int threads = options.num_threads;

  // a float box per triangle, rounded outwards so it contains the double triangle
  // (left uninitialised until then: the threads touch their own pages first)
  const std::unique_ptr<PrimRef[]> refs(new PrimRef[n]);
  ParallelFor(n, threads, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const Triangle t = mesh_->triangle(source[i]);
      const Vector3 lo = t.v0.cwiseMin(t.v1).cwiseMin(t.v2);
      const Vector3 hi = t.v0.cwiseMax(t.v1).cwiseMax(t.v2);
      refs[i].lo = Float4{RoundDownToFloat(lo.x()), RoundDownToFloat(lo.y()), RoundDownToFloat(lo.z()),
                          PrimRef::EncodeIndex(source[i])};
      refs[i].hi = Float4{RoundUpToFloat(hi.x()), RoundUpToFloat(hi.y()), RoundUpToFloat(hi.z()), 0};
    }
  });

  // the tree; a root whose whole range is one leaf gets an empty second slot
  Range all;
  all.begin = 0;
  all.end = n;
  for (int i = 0; i < n; ++i) all.Add(refs[i]);
  // a tree whose nodes have two or more children has fewer nodes than leaves; pages
  // of the reserve that are never written cost no memory
  nodes_.reserve(std::max(n - 1, 1));
  Builder builder(refs.get(), options);
  const PlannedRange root = builder.Plan(all, 0, threads > 1);
  if (root.leaf) {
    // the whole mesh is one leaf: a root with one slot used
    BvhNode node;
    for (int c = 0; c < kBvhWidth; ++c) {
      for (int a = 0; a < 3; ++a) {
        node.lo[a][c] = c == 0 ? WidenLow(all.box.lo[a]) : kInf;
        node.hi[a][c] = c == 0 ? WidenHigh(all.box.hi[a]) : -kInf;
      }
      node.child[c] = ~0;
      node.count[c] = c == 0 ? n : 0;
    }
    nodes_.push_back(node);
    depth_ = 1;
  } else {
    builder.Build(root, 0, threads - 1, nodes_, depth_);
  }

  // the triangles in leaf order, for the queries
  primitives_.resize(n);
  primitive_triangles_.resize(n);
  ParallelFor(n, threads, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      primitive_triangles_[i] = refs[i].index();
      primitives_[i] = mesh_->triangle(refs[i].index());
    }
  });

  // the discs about each node's children
  std::vector<PrimitiveRange> ranges(nodes_.size());
  FillRanges(nodes_, 0, ranges);
  discs_.resize(nodes_.size());
  ParallelFor(static_cast<int>(nodes_.size()), threads, [&](int begin, int end) {
    for (int node = begin; node < end; ++node) {
      BvhDiscs& discs = discs_[node];
      for (int c = 0; c < kBvhWidth; ++c) {
        for (int a = 0; a < 3; ++a) {
          discs.centre[a][c] = 0;
          discs.normal[a][c] = a == 2;
        }
        discs.radius[c] = kInf;
        discs.thickness[c] = kInf;
        const PrimitiveRange range = ChildRange(nodes_, ranges, node, c);
        FitDisc(std::span<const Triangle>(primitives_).subspan(range.begin, range.end - range.begin), c, discs);
      }
    }
  });
}

Aabb MeshBvh::bounds() const {
  Aabb box;
  for (int c = 0; c < kBvhWidth; ++c) {
    if (!nodes_[0].is_empty(c)) box.Extend(nodes_[0].child_bounds(c));
  }
  return box;
}

float RoundDownToFloat(double x) {
  if (!(x > -kFloatMax)) return -kFloatMax;
  if (x > kFloatMax) return kFloatMax;
  float f = static_cast<float>(x);
  // rounded up: one float step down (from zero, to the smallest negative float)
  if (static_cast<double>(f) > x) {
    const int32_t bits = std::bit_cast<int32_t>(f);
    constexpr float kSmallestNegative = -std::numeric_limits<float>::denorm_min();
    f = f > 0 ? std::bit_cast<float>(bits - 1)
              : (f == 0 ? kSmallestNegative : std::bit_cast<float>(bits + 1));
  }
  return f;
}
float RoundUpToFloat(double x) { return -RoundDownToFloat(-x); }

}  // namespace hapticd::geometry
