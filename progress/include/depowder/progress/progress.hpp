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

#include <memory>
#include <string>

#include "depowder/geometry.hpp"
#include "depowder/point_grid.hpp"
#include "depowder/progress/footprint.hpp"

namespace depowder::progress {

struct ProgressConfig {
  double eta1 = 0.30;               ///< phase 1 -> 2 threshold (paper: 30 %)
  double eta2 = 0.85;               ///< phase 2 -> 3 threshold (paper: 85 %)
  double band_offset = 0.0;         ///< m added to xi: the contour band starts at xi + band_offset from the part
  double band_width = 0.005;        ///< m, band width (authors: (xi, xi + 0.5 cm))
  double top_margin = 0.005;        ///< m; unless the part is covered, band points must lie below H_max + top_margin
                                    ///< (authors: 0; 5 mm keeps depth noise at the top from biasing H_pow down)
  int min_band_points = 10;         ///< fewer powder points in the band: NO_CONTOUR, eta not updated
  double cover_margin = 0.03;       ///< m; scan points over the footprint within [H_max - xi, H_max + this] are
                                    ///< part (paper footnote: the top of a covered part)
  double outlier_mad_k = 3.0;       ///< band heights beyond k * 1.4826 * MAD of the median are outliers (0: keep all)
  double outlier_floor = 0.005;     ///< m, a band height within this of the median is never an outlier
  double grid_cell = 0.002;         ///< m, raster cell of the footprint (silhouette, holes, contour)
  double contour_spacing = 0.01;    ///< m between vertices of the contour polyline
  double contour_radius = 0.01;     ///< m; a contour vertex's height = median band height within this (2-D)
  int contour_min_points = 3;       ///< fewer band points within contour_radius: the vertex height is interpolated
  double footprint_reuse = 0.0005;  ///< m; EtaEstimator keeps its footprint while the posed CAD's projection is
                                    ///< within this of a 2-D rigid motion (yaw, xy) of it (0: rebuild every call)
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
  bool covered = false;           ///< the band's lower quartile height is at or above H_max: the part is buried
  Cloud band;                     ///< the powder points of the contour band (cell frame), outliers removed
  Cloud contour;                  ///< ordered closed polyline around the part (cell frame), counter-clockwise
  Cloud part;                     ///< scan points segmented as part (cell frame)
  std::size_t part_points = 0;    ///< part.size()
  std::size_t band_outliers = 0;  ///< band candidates rejected as height outliers or above the top
};

/// The first problem of `config` for a part of template distance `xi` (m), or "" if none: what
/// estimateProgress refuses as kBadConfig on every frame (a node checks its options with it once).
std::string checkConfig(double xi, const ProgressConfig& config);

/// `cad_in_cell`: the CAD surface samples transformed to the current pose (P_cad . T_i);
/// `scan`: the cell-frame cloud P_i; `xi`: the part's template distance threshold (m).
/// Never throws; bad input (empty, NaN) gives a status and reason.
ProgressEstimate estimateProgress(const Cloud& cad_in_cell, const Cloud& scan, double xi,
                                  const ProgressConfig& config = {});

/// Eq. 2 for one part, frame after frame, without the contour: what the tracker needs (Alg. 1,
/// line 11). Steps 1-6 of estimateProgress run through the same code; what differs is what is
/// kept between calls: the CAD samples' grid is built once in the part frame (scan points are
/// moved into it), and the footprint is rebuilt only when the pose has changed it. While the
/// projection of P_cad . T_i stays within `footprint_reuse` of a 2-D rigid motion (a turn about
/// the vertical, a slide) of the projection the footprint was built from, scan points are moved by
/// the inverse of that motion into the old footprint. With a fresh footprint the result equals
/// estimateProgress(transformed(cad, T), ...) (test_progress); `contour` and `part` stay empty.
/// Not thread-safe: one estimator per part and thread.
class EtaEstimator {
 public:
  EtaEstimator() = default;
  /// `cad_part`: P_cad in the part frame; `xi`: the part's template distance (m).
  EtaEstimator(Cloud cad_part, double xi, const ProgressConfig& config = {});

  /// Eq. 2 at pose `T_cell_part` from the cell-frame scan. Never throws; bad input gives a status.
  ProgressEstimate estimate(const Pose& T_cell_part, const Cloud& scan);

  /// The last estimate() reused the footprint of an earlier pose.
  bool reusedFootprint() const { return reused_; }

 private:
  std::shared_ptr<const Cloud> cad_;  ///< part frame; shared so that copies keep grid_ valid
  double xi_ = 0;
  ProgressConfig config_;
  PointGrid grid_;                ///< over *cad_, cell xi (built on the first valid call)
  Eigen::AlignedBox3d near_box_;  ///< part frame: the samples' bounds grown by xi
  Cloud cad_in_cell_;             ///< P_cad . T_i, this call
  Footprint footprint_;
  Cloud footprint_cad_;                  ///< the posed samples the footprint was built from
  Eigen::AlignedBox2d band_box_;         ///< footprint frame: its samples' xy bounds grown by the band's outer radius
  Pose T_footprint_ = Pose::Identity();  ///< the pose it was built at
  bool have_footprint_ = false;
  bool reused_ = false;
};

/// Eq. 2 alone: (h_max - min(h_pow, h_max)) / (h_max - h_min), clamped to [0, 1].
/// Requires h_max > h_min.
double etaFromHeights(double h_pow, double h_max, double h_min);

}  // namespace depowder::progress
