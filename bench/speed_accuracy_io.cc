#include "bench/speed_accuracy_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <utility>

namespace hapticd::bench {
namespace {

static_assert(std::endian::native == std::endian::little, ".npy files are written little-endian");

// The value at quantile q of sorted values (nearest rank).
double AtQuantile(const std::vector<double>& sorted, double q) {
  const size_t rank = static_cast<size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

// Six significant digits: more than a timing or an error statistic carries.
std::string Number(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", x);
  return text;
}

// The .npy header: magic, version 1.0, a Python dict literal padded to 64 bytes.
std::string NpyHeader(const char* descr, const std::vector<int64_t>& shape) {
  std::string dims;
  for (int64_t d : shape) dims += std::to_string(d) + ", ";
  if (shape.size() > 1) dims.resize(dims.size() - 1);
  std::string dict = std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': (" +
                     dims + "), }";
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  std::string header("\x93NUMPY\x01\x00", 8);
  header += static_cast<char>(dict.size() & 0xff);
  header += static_cast<char>(dict.size() >> 8);
  return header + dict;
}

void WriteRaw(const std::string& path, const std::string& header, const void* data, size_t bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

ErrorStats SummarizeErrors(std::vector<double> errors, int misses) {
  std::sort(errors.begin(), errors.end());
  ErrorStats stats;
  stats.max = errors.back();
  stats.p99 = AtQuantile(errors, 0.99);
  stats.median = AtQuantile(errors, 0.5);
  stats.misses = misses;
  return stats;
}

int TimedBatchSize(int n, double pass_s, const TimingOptions& options, int min_items) {
  const double affordable = n * options.budget_s / (options.min_reps * std::max(pass_s, 1e-12));
  return static_cast<int>(std::clamp(affordable, std::min(1.0 * min_items, 1.0 * n), 1.0 * n));
}

BatchTiming MedianTiming(std::vector<double> per_item_ns) {
  std::sort(per_item_ns.begin(), per_item_ns.end());
  BatchTiming timing;
  timing.reps = static_cast<int>(per_item_ns.size());
  timing.min_ns = per_item_ns.front();
  // the lower median of an even count: a rep slowed by other work is never picked
  timing.median_ns = per_item_ns[(per_item_ns.size() - 1) / 2];
  return timing;
}

ResultRow MakeHapticdRow(std::string surface, std::string representation, int level, int64_t triangles,
                         std::string backend) {
  ResultRow row;
  row.surface = std::move(surface);
  row.representation = std::move(representation);
  row.level = level;
  row.triangles = triangles;
  row.implementation = std::string("hapticd");
  row.backend = std::move(backend);
  return row;
}

std::string CsvHeader() {
  return "query,surface,representation,level,triangles,implementation,backend,queries,reps,"
         "time_ns,time_ns_min,overhead_ns,error_unit,error_max,error_p99,error_median,misses,note";
}

std::string CsvLine(const ResultRow& r) {
  return r.query + "," + r.surface + "," + r.representation + "," + std::to_string(r.level) + "," +
         std::to_string(r.triangles) + "," + r.implementation + "," + r.backend + "," +
         std::to_string(r.queries) + "," + std::to_string(r.reps) + "," + Number(r.time_ns) + "," +
         Number(r.time_ns_min) + "," + Number(r.overhead_ns) + "," + r.error_unit + "," +
         Number(r.error.max) + "," + Number(r.error.p99) + "," + Number(r.error.median) + "," +
         std::to_string(r.error.misses) + "," + CsvQuoted(r.note);
}

std::string CsvQuoted(const std::string& text) {
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void WriteNpy(const std::string& path, std::span<const double> values, std::vector<int64_t> shape) {
  WriteRaw(path, NpyHeader("<f8", shape), values.data(), values.size_bytes());
}

void WriteNpy(const std::string& path, std::span<const int32_t> values, std::vector<int64_t> shape) {
  WriteRaw(path, NpyHeader("<i4", shape), values.data(), values.size_bytes());
}

void WriteNpy(const std::string& path, std::span<const geometry::Vector3> points) {
  std::vector<double> flat;
  flat.reserve(3 * points.size());
  for (const geometry::Vector3& p : points) flat.insert(flat.end(), {p.x(), p.y(), p.z()});
  WriteNpy(path, flat, {static_cast<int64_t>(points.size()), 3});
}

}  // namespace hapticd::bench
