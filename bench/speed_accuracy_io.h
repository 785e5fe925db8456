#pragma once

// What the speed-accuracy program measures and writes: the median time per query of a
// repeated batch, error statistics, one CSV row per (query, surface, representation,
// level, backend), and .npy files the Python peers read the same inputs from.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::bench {

// Error of a batch of answers against the ground truth, in the row's unit.
struct ErrorStats {
  double max = 0;
  double p99 = 0;     // nearest rank
  double median = 0;
  int misses = 0;     // first hits: segments the representation did not hit
};

// Statistics of errors (any order; not empty).
ErrorStats SummarizeErrors(std::vector<double> errors, int misses = 0);

// One CSV row; peers write the same columns (bench/speed_accuracy_peers.py).
struct ResultRow {
  std::string query;           // closest_point, first_hit, force_point, force_sphere
  std::string surface;         // sphere, torus
  std::string representation;  // primitive, hull, mesh
  int level = -1;              // tessellation level 0..4; -1 for the primitive
  int64_t triangles = 0;       // of the mesh or of the hull; 0 for the primitive
  std::string implementation;  // hapticd, coal, python-fcl, embreex
  std::string backend;         // native, embree, embree_raw (unconfirmed float), ...
  int queries = 0;             // per batch (force rows: timed ticks per batch)
  int reps = 0;                // timed repetitions of the batch
  double time_ns = 0;          // median over reps of the batch time / queries
  double time_ns_min = 0;      // fastest rep
  double overhead_ns = 0;      // the same call on a trivial input (first hit: segments that miss)
  std::string error_unit;      // m or N
  ErrorStats error;
  std::string note;
};

// A hapticd row's identity; the measurement fills in the rest.
ResultRow MakeHapticdRow(std::string surface, std::string representation, int level, int64_t triangles,
                         std::string backend);

// The CSV header line and one row (no trailing newline).
std::string CsvHeader();
std::string CsvLine(const ResultRow& row);
// text in double quotes, inner quotes doubled.
std::string CsvQuoted(const std::string& text);

// Writes a little-endian .npy (format 1.0) of doubles or int32 with the given shape.
// Throws std::runtime_error naming the file when it cannot be written.
void WriteNpy(const std::string& path, std::span<const double> values, std::vector<int64_t> shape);
void WriteNpy(const std::string& path, std::span<const int32_t> values, std::vector<int64_t> shape);
// Points as an n x 3 array.
void WriteNpy(const std::string& path, std::span<const geometry::Vector3> points);

// How a batch is repeated: at least min_reps, at most max_reps, and no more once
// budget_s seconds have been spent on timed reps.
struct TimingOptions {
  int min_reps = 3;
  int max_reps = 9;
  double budget_s = 0.5;
};

struct BatchTiming {
  double median_ns = 0;  // per item
  double min_ns = 0;
  int reps = 0;
};

// How many of n items to time, given that one timed pass over all n would take pass_s:
// all of them, unless min_reps passes would overrun budget_s (slow representations);
// then as many as fit, but at least min_items (or n).
int TimedBatchSize(int n, double pass_s, const TimingOptions& options, int min_items = 64);

// Seconds since begin, on the steady clock.
inline double SecondsSince(std::chrono::steady_clock::time_point begin) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
}

// Median and minimum of per-item times (not empty).
BatchTiming MedianTiming(std::vector<double> per_item_ns);

// Times run_batch() (which does `items` queries and returns a checksum, kept so that
// the work is not optimised away) under options; the caller runs it once untimed first.
template <class RunBatch>
BatchTiming TimeBatch(int items, const TimingOptions& options, RunBatch&& run_batch) {
  std::vector<double> per_item;
  double spent_s = 0;
  volatile double sink = 0;
  while (static_cast<int>(per_item.size()) < options.max_reps &&
         (static_cast<int>(per_item.size()) < options.min_reps || spent_s < options.budget_s)) {
    const auto begin = std::chrono::steady_clock::now();
    sink = sink + run_batch();
    const auto end = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(end - begin).count();
    spent_s += seconds;
    per_item.push_back(1e9 * seconds / items);
  }
  return MedianTiming(std::move(per_item));
}

}  // namespace hapticd::bench
