// From the rasteriser's clean depth to a DepthImage: range limits, quantisation and
// the L515-like artefacts of DepthNoise. The noise model, per pixel:
//   - range noise: range r += N(0, sigma_base + sigma_per_m * r) along the pixel's ray;
//   - flying pixels: a pixel whose 4-neighbour differs by more than flying_edge returns,
//     with probability flying_pixel_prob, a depth uniformly between its own and that
//     neighbour's (the beam straddles the edge);
//   - grazing drop-outs: beyond grazing_dropout_deg of incidence the return is lost with a
//     probability that ramps linearly to 1 at 90 deg;
//   - random drop-outs with probability dropout_prob.
// One std::mt19937 draw per pixel (high 13 bits: a normal deviate from an 8192-entry
// quantile table; low 16 bits: the drop-out test), plus extra draws only at edge and
// grazing pixels; so a frame costs about one generator call per pixel.
#pragma once

#include <random>

#include "depowder/sim/camera.hpp"
#include "depowder/sim/raster.hpp"

namespace depowder::sim {

/// Fills `out` from `raster` (rendered for `camera`). With `rng` == nullptr, no noise:
/// only the range limits [min_range, max_range] (on the ray's range) and quantisation to
/// `depth_unit` (rounded to nearest).
void makeDepthImage(const DepthRasterizer& raster, const CameraModel& camera, double depth_unit, std::mt19937* rng,
                    DepthImage& out);

/// Range sigma (m) of the model at range r (m).

/// Probability of a grazing drop-out at incidence angle `incidence_deg`.
double grazingDropoutProbability(const DepthNoise& n, double incidence_deg);

}  // namespace depowder::sim
