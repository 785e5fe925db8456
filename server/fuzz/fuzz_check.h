#pragma once
// What every fuzz target shares: a check that turns a broken invariant into a crash
// libFuzzer reports (with the message on stderr and the input saved as crash-*).

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Core>

// Aborts with the condition, the file and line, and a printf-style explanation.
#define FUZZ_CHECK(condition, ...)                                               \
  do {                                                                           \
    if (!(condition)) {                                                          \
      std::fprintf(stderr, "%s:%d: FUZZ_CHECK(%s) failed: ", __FILE__, __LINE__, \
                   #condition);                                                  \
      std::fprintf(stderr, __VA_ARGS__);                                         \
      std::fputc('\n', stderr);                                                  \
      std::abort();                                                              \
    }                                                                            \
  } while (false)

namespace hapticd::fuzz {

// The same double, NaN included (a NaN in equals a NaN out; -0 equals +0).
inline bool SameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

// Coefficient by coefficient, as SameValue.
template <typename DerivedA, typename DerivedB>
bool SameValues(const Eigen::DenseBase<DerivedA>& a, const Eigen::DenseBase<DerivedB>& b) {
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    if (!SameValue(a.derived().coeff(i), b.derived().coeff(i))) return false;
  }
  return true;
}

}  // namespace hapticd::fuzz
