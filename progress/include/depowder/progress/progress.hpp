// Progress estimation (paper Sec. IV-C, Fig. 8, Eq. 2): segment the scan into part
// and powder with the part's pose, take the powder contour around the part, and
// eta = (H_max - H_pow) / (H_max - H_min). A pure function of its inputs: the
// tracker calls it for its update rule (Alg. 1, line 11), the progress process
// for the contour, eta and phase the planner acts on.
//
// The band is measured from the posed CAD's filled xy silhouette (footprint.hpp),
// like the authors' 2-D distance on the z = 0 projection (REFERENCE.md). H_pow is
// the mean band height after rejecting height outliers (nozzle, arm, flying
// pixels) by median / MAD; the paper says "mean", and without outliers it is.
#pragma once

#include <string>

#include "depowder/geometry.hpp"

namespace depowder::progress {

struct ProgressConfig {
  double eta1 = 0.30;             ///< phase 1 -> 2 threshold (paper: 30 %)
  double eta2 = 0.85;             ///< phase 2 -> 3 threshold (paper: 85 %)
  double band_offset = 0.0;       ///< m added to xi: the contour band starts at xi + band_offset from the part
  double band_width = 0.005;      ///< m, band width (authors: (xi, xi + 0.5 cm))
  double top_margin = 0.005;      ///< m; unless the part is covered, band points must lie below H_max + top_margin
                                  ///< (authors: 0; 5 mm keeps depth noise at the top from biasing H_pow down)
  int min_band_points = 10;       ///< fewer powder points in the band: NO_CONTOUR, eta not updated
  double cover_margin = 0.03;     ///< m; scan points over the footprint within [H_max - xi, H_max + this] are
                                  ///< part (paper footnote: the top of a covered part)
  double outlier_mad_k = 3.0;     ///< band heights beyond k * 1.4826 * MAD of the median are outliers (0: keep all)
  double outlier_floor = 0.005;   ///< m, a band height within this of the median is never an outlier
  double grid_cell = 0.002;       ///< m, raster cell of the footprint (silhouette, holes, contour)
  double contour_spacing = 0.01;  ///< m between vertices of the contour polyline
  double contour_radius = 0.01;   ///< m; a contour vertex's height = median band height within this (2-D)
  int contour_min_points = 3;     ///< fewer band points within contour_radius: the vertex height is interpolated
};

enum class Status {
  kOk,
  kNoPose,     ///< no CAD samples, or NaN/inf in them (invalid pose), or no height span
  kNoPoints,   ///< empty scan or all points NaN/inf
  kNoContour,  ///< fewer than min_band_points powder points in the band: eta not updated
  kBadConfig,  ///< xi or a config field is out of range (the reason names it)
};
const char* toString(Status s);

/// One frame's Eq. 2 estimate for one part.
struct ProgressEstimate {
  Status status = Status::kNoPoints;
  std::string reason;             ///< why, when status != kOk
  double eta = 0;                 ///< Eq. 2, in [0, 1] (H_pow clamped to H_max, eta to <= 1)
  double h_pow = 0;               ///< mean height of the powder contour, m (cell z), before clamping
  double h_max = 0;               ///< CAD top at the current pose, m
  double h_min = 0;               ///< CAD bottom at the current pose, m
  bool covered = false;           ///< the band's median height is above H_max: the part is buried
  Cloud band;                     ///< the powder points of the contour band (cell frame), outliers removed
  Cloud contour;                  ///< ordered closed polyline around the part (cell frame), counter-clockwise
  Cloud part;                     ///< scan points segmented as part (cell frame)
  std::size_t part_points = 0;    ///< part.size()
  std::size_t band_outliers = 0;  ///< band candidates rejected as height outliers or above the top
};

/// `cad_in_cell`: the CAD surface samples transformed to the current pose (P_cad . T_i);
/// `scan`: the cell-frame cloud P_i; `xi`: the part's template distance threshold (m).
/// Never throws; bad input (empty, NaN) gives a status and reason.
ProgressEstimate estimateProgress(const Cloud& cad_in_cell, const Cloud& scan, double xi,
                                  const ProgressConfig& config = {});

/// Eq. 2 alone: (h_max - min(h_pow, h_max)) / (h_max - h_min), clamped to [0, 1].
/// Requires h_max > h_min.
double etaFromHeights(double h_pow, double h_max, double h_min);

}  // namespace depowder::progress
