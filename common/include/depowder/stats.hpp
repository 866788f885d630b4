// Summary statistics of measured figures (the tools' and benches' latency and error percentiles).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace depowder {

/// The q-quantile (q in [0, 1]) of `v`: the element at rank round(q (n - 1)) of the sorted
/// values; NaN if `v` is empty.
inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  const auto k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// The q-quantile of `v` interpolated linearly between the two ranks that q (n - 1) falls
/// between (the benches' rule); NaN if `v` is empty.
inline double interpolatedPercentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  return i + 1 < v.size() ? v[i] + (pos - static_cast<double>(i)) * (v[i + 1] - v[i]) : v.back();
}

}  // namespace depowder
