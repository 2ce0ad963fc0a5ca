// Statistics used across libraries: one definition of the median and of percentiles, so every
// report and check computes them the same way (nearest rank, no interpolation), and of the
// sample standard deviation.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace gonio {

// The q-quantile (q in [0, 1]) by nearest rank: element round(q * (n - 1)) of the sorted values.
// NaN for an empty vector, so a caller cannot mistake "no data" for a value.
inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  const double qc = std::clamp(q, 0.0, 1.0);
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(qc * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// The upper median (element n / 2 of the sorted values); NaN for an empty vector.
inline double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// The sample standard deviation (n - 1 in the denominator); NaN for fewer than two values.
inline double SampleStddev(const std::vector<double>& v) {
  if (v.size() < 2) return std::nan("");
  double mean = 0;
  for (double x : v) mean += x;
  mean /= v.size();
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / (v.size() - 1));
}

}  // namespace gonio
