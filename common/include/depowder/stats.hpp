// Summary statistics of measured figures (the tools' and benches' latency and error percentiles).
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>
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

/// The Wilson score interval of a success rate: `successes` of `n` trials, `z` the standard normal
/// quantile (1.96: 95 %). {low, high} within [0, 1]; NaNs for n <= 0 or successes outside [0, n].
/// With 25 trials a rate is known only to about +-15 points: 20 of 25 gives [0.61, 0.91].
inline std::pair<double, double> wilsonInterval(double successes, double n, double z = 1.96) {
  if (!(n > 0) || !(successes >= 0 && successes <= n)) return {std::nan(""), std::nan("")};
  const double p = successes / n, z2n = z * z / n;
  const double centre = (p + 0.5 * z2n) / (1 + z2n);
  const double half = z * std::sqrt(p * (1 - p) / n + 0.25 * z2n / n) / (1 + z2n);
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

}  // namespace depowder
