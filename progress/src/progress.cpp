#include "depowder/progress/progress.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "depowder/point_grid.hpp"
#include "depowder/progress/footprint.hpp"

namespace depowder::progress {
namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// The q-quantile (nearest rank) of v; v is reordered.
double quantile(std::vector<double>& v, double q) {
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

/// Heights of the contour vertices: the median band height within `radius` where at least
/// `min_points` band points are (one or two lone points are often voxels that mix part and powder);
/// other vertices are interpolated along the loop from their measured neighbours.
void liftContour(const Polyline2& loop, const Cloud& band, double radius, int min_points, double fallback, Cloud& out) {
  const std::size_t n = loop.size();
  std::vector<double> z(n, 0.0), near;
  std::vector<char> known(n, 0);
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < n; ++i) {
    near.clear();
    for (const Point& p : band)
      if ((p.head<2>() - loop[i]).squaredNorm() <= r2) near.push_back(p.z());
    if (static_cast<int>(near.size()) >= min_points) z[i] = quantile(near, 0.5), known[i] = 1;
  }
  const auto first = std::find(known.begin(), known.end(), 1);
  if (first == known.end()) {
    std::fill(z.begin(), z.end(), fallback);
  } else {
    // Walk once around from a measured vertex, filling each gap linearly between its ends.
    const std::size_t k0 = static_cast<std::size_t>(first - known.begin());
    std::size_t last = k0;
    for (std::size_t step = 1; step <= n; ++step) {
      const std::size_t i = (k0 + step) % n;
      if (!known[i]) continue;
      const std::size_t gap = (i + n - last) % n == 0 ? n : (i + n - last) % n;
      for (std::size_t g = 1; g < gap; ++g) z[(last + g) % n] = z[last] + (z[i] - z[last]) * double(g) / gap;
      last = i;
    }
  }
  out.clear();
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) out.emplace_back(loop[i].x(), loop[i].y(), z[i]);
}

ProgressEstimate& fail(ProgressEstimate& out, Status s, std::string why) {
  out.status = s;
  out.reason = std::move(why);
  return out;
}

/// The band's radii from the footprint (Fig. 8b): (r_in, r_out].
struct Band {
  double r_in, r_out;
};
Band bandOf(double xi, const ProgressConfig& c) { return {xi + c.band_offset, xi + c.band_offset + c.band_width}; }

Eigen::AlignedBox3d grown(Eigen::AlignedBox3d box, double margin) {
  box.min().array() -= margin;
  box.max().array() += margin;
  return box;
}

/// The xy bounds of the posed samples grown by the band's outer radius: no band point lies outside.
Eigen::AlignedBox2d bandBox(const Cloud& cad_in_cell, double r_out) {
  const Eigen::AlignedBox3d b = bounds(cad_in_cell);
  return {b.min().head<2>().array() - r_out, b.max().head<2>().array() + r_out};
}

/// The posed part as steps 4-5 query it. Footprint and CAD grid may have been built at another
/// pose or in another frame (EtaEstimator): `to_footprint` maps cell xy into the footprint's
/// frame, `to_grid` cell points into the grid's. estimateProgress builds both at the pose.
struct PosedPart {
  const Footprint& footprint;
  Eigen::Isometry2d to_footprint;
  Eigen::AlignedBox2d band_box;  ///< footprint frame
  const PointGrid& cad_grid;     ///< the CAD samples, cell xi
  Pose to_grid;
  Eigen::AlignedBox3d near_box;  ///< grid frame: the samples' bounds grown by xi
};

/// Steps 1-2: the inputs, then H_max and H_min, the CAD's top and bottom at the current pose
/// (Eq. 2). False, with out's status and reason set, if the inputs are bad.
bool checkInputsAndHeights(const Cloud& cad_in_cell, const Cloud& scan, double xi, const ProgressConfig& config,
                           ProgressEstimate& out) {
  if (std::string why = checkConfig(xi, config); !why.empty()) return fail(out, Status::kBadConfig, why), false;
  if (cad_in_cell.empty()) return fail(out, Status::kNoPose, "no CAD samples (no pose or no model)"), false;
  for (const Point& p : cad_in_cell)
    if (!p.allFinite()) return fail(out, Status::kNoPose, "CAD samples contain NaN/inf: the pose is invalid"), false;
  if (scan.empty()) return fail(out, Status::kNoPoints, "the scan is empty"), false;
  out.h_max = -std::numeric_limits<double>::infinity();
  out.h_min = std::numeric_limits<double>::infinity();
  for (const Point& p : cad_in_cell) out.h_max = std::max(out.h_max, p.z()), out.h_min = std::min(out.h_min, p.z());
  if (out.h_max - out.h_min < 1e-4)
    return fail(out, Status::kNoPose, "CAD samples span no height (< 0.1 mm in z)"), false;
  return true;
}

/// Steps 4-6: segmentation, band, H_pow and Eq. 2. Part points go to `part` if given. False, with
/// out's status and reason set, if there is no band.
bool segmentAndEstimate(const PosedPart& g, const Cloud& scan, double xi, const ProgressConfig& config,
                        ProgressEstimate& out, Cloud* part) {
  const Band band = bandOf(xi, config);
  const double r_in = band.r_in, r_out = band.r_out;  // named, not bound: lambdas below use them

  // 4. Segmentation (Fig. 8a) and band candidates (Fig. 8b).
  const double slack = 1.5 * config.grid_cell;
  std::size_t finite = 0;
  Cloud candidates;
  for (const Point& p : scan) {
    if (!p.allFinite()) continue;
    ++finite;
    const Point2 q = g.to_footprint * p.head<2>();
    if (!g.band_box.contains(q)) continue;
    // The raster distance is within sqrt(2) cells of the exact 2-D one: it settles most points, the
    // exact (slower) distances only those near the band's edges. 3-D distance >= 2-D distance.
    const double f = g.footprint.rasterDistance(q);  // -1 in a filled hole, +inf off the raster
    if (f > r_out + slack) continue;                 // powder away from the part
    if (f <= xi + slack) {
      const Point in_grid = g.to_grid * p;
      if (g.near_box.contains(in_grid) && g.cad_grid.anyWithin(in_grid, xi)) {
        ++out.part_points;  // within xi of the posed CAD surface
        if (part) part->push_back(p);
        continue;
      }
    }
    // Within r_in of the silhouette (exact 2-D distance), or inside it (holes: -1).
    const bool over_part = f < r_in - slack || g.footprint.within(q, r_in);
    if (over_part || !g.footprint.outside(q)) {
      // Over the part: its top when the part is buried (paper footnote), else powder on or in it.
      if (p.z() >= out.h_max - xi && p.z() <= out.h_max + config.cover_margin) {
        ++out.part_points;
        if (part) part->push_back(p);
      }
      continue;
    }
    if (g.footprint.within(q, r_out)) candidates.push_back(p);  // in (r_in, r_out]
  }
  if (finite == 0)
    return fail(out, Status::kNoPoints, "all " + std::to_string(scan.size()) + " points are NaN/inf"), false;
  auto noContour = [&](std::size_t n) {
    fail(out, Status::kNoContour,
         std::to_string(n) + " powder points in the band (" + fmt(r_in * 100) + ", " + fmt(r_out * 100) +
             "] cm around the part, need " + std::to_string(config.min_band_points));
    return false;
  };
  if (candidates.size() < static_cast<std::size_t>(config.min_band_points)) return noContour(candidates.size());

  // 5. H_pow: mean band height. The part is buried when the bulk of the band (its lower quartile)
  // is above H_max; otherwise points above the CAD top are dropped first (the authors' rule: it
  // drops the nozzle, the arm, and part points a wrong pose puts in the band). Then height outliers
  // are dropped by median / MAD.
  std::vector<double> z;
  z.reserve(candidates.size());
  for (const Point& p : candidates) z.push_back(p.z());
  out.covered = quantile(z, 0.25) >= out.h_max;
  if (!out.covered) {
    z.clear();
    for (const Point& p : candidates)
      if (p.z() <= out.h_max + config.top_margin) z.push_back(p.z());
    if (z.size() < static_cast<std::size_t>(config.min_band_points)) {
      out.band_outliers = candidates.size() - z.size();
      return noContour(z.size());
    }
  }
  const double med = quantile(z, 0.5);
  for (double& v : z) v = std::abs(v - med);
  const double mad = quantile(z, 0.5);
  const double keep = config.outlier_mad_k > 0 ? std::max(config.outlier_mad_k * 1.4826 * mad, config.outlier_floor)
                                               : std::numeric_limits<double>::infinity();
  double sum = 0;
  for (const Point& p : candidates) {
    const bool inlier = std::abs(p.z() - med) <= keep && (out.covered || p.z() <= out.h_max + config.top_margin);
    if (inlier) {
      out.band.push_back(p);
      sum += p.z();
    }
  }
  out.band_outliers = candidates.size() - out.band.size();
  if (out.band.size() < static_cast<std::size_t>(config.min_band_points)) return noContour(out.band.size());
  out.h_pow = sum / out.band.size();

  // 6. Eq. 2.
  out.eta = etaFromHeights(out.h_pow, out.h_max, out.h_min);
  out.status = Status::kOk;
  return true;
}

/// If the posed samples `now` are within `tolerance` (xy) of a 2-D rigid motion of the same samples
/// posed earlier (`then`), that motion's inverse (now -> then). `R_delta`: the rotation between the
/// two poses, whose turn about the vertical is the motion's; its translation aligns the centroids.
bool planarMotion(const Cloud& then, const Cloud& now, const Eigen::Matrix3d& R_delta, double tolerance,
                  Eigen::Isometry2d& now_to_then) {
  if (then.size() != now.size() || now.empty()) return false;
  const Eigen::Rotation2Dd turn(turnAboutVertical(R_delta));
  Eigen::Vector2d c_then = Eigen::Vector2d::Zero(), c_now = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < now.size(); ++i) c_then += then[i].head<2>(), c_now += now[i].head<2>();
  c_then /= static_cast<double>(then.size());
  c_now /= static_cast<double>(now.size());
  Eigen::Isometry2d then_to_now = Eigen::Isometry2d::Identity();
  then_to_now.linear() = turn.toRotationMatrix();
  then_to_now.translation() = c_now - turn * c_then;
  const double tol2 = tolerance * tolerance;
  for (std::size_t i = 0; i < now.size(); ++i)
    if ((now[i].head<2>() - then_to_now * then[i].head<2>()).squaredNorm() > tol2) return false;
  now_to_then = then_to_now.inverse(Eigen::Isometry);
  return true;
}

}  // namespace

std::string checkConfig(double xi, const ProgressConfig& c) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(xi)) return "xi must be a positive distance in m, got " + fmt(xi);
  if (!positive(c.band_width)) return "band_width must be > 0 m, got " + fmt(c.band_width);
  if (!std::isfinite(c.band_offset) || xi + c.band_offset <= 0)
    return "band_offset must keep xi + band_offset > 0, got " + fmt(c.band_offset) + " with xi " + fmt(xi);
  if (!std::isfinite(c.top_margin)) return "top_margin must be finite";
  if (!std::isfinite(c.cover_margin) || c.cover_margin < 0) return "cover_margin must be >= 0 m";
  if (c.min_band_points < 1) return "min_band_points must be >= 1";
  if (!std::isfinite(c.outlier_mad_k) || c.outlier_mad_k < 0) return "outlier_mad_k must be >= 0";
  if (!std::isfinite(c.outlier_floor) || c.outlier_floor < 0) return "outlier_floor must be >= 0 m";
  if (!positive(c.grid_cell)) return "grid_cell must be > 0 m";
  if (!positive(c.contour_spacing)) return "contour_spacing must be > 0 m";
  if (!positive(c.contour_radius)) return "contour_radius must be > 0 m";
  if (c.contour_min_points < 1) return "contour_min_points must be >= 1";
  if (!std::isfinite(c.footprint_reuse) || c.footprint_reuse < 0) return "footprint_reuse must be >= 0 m";
  return "";
}

const char* toString(Status s) {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kNoPose:
      return "no_pose";
    case Status::kNoPoints:
      return "no_points";
    case Status::kNoContour:
      return "no_contour";
    case Status::kBadConfig:
      return "bad_config";
  }
  return "unknown";
}

double etaFromHeights(double h_pow, double h_max, double h_min) {
  // Eq. 2; "if H_pow is higher than H_max, H_pow is truncated to H_max" (Sec. IV-C). Below the
  // bottom (powder dug under the part) the part is fully uncovered: eta is capped at 1.
  const double eta = (h_max - std::min(h_pow, h_max)) / (h_max - h_min);
  return std::clamp(eta, 0.0, 1.0);
}

ProgressEstimate estimateProgress(const Cloud& cad_in_cell, const Cloud& scan, double xi,
                                  const ProgressConfig& config) {
  ProgressEstimate out;
  if (!checkInputsAndHeights(cad_in_cell, scan, xi, config, out)) return out;

  // 3. The footprint and the CAD grid at this pose.
  const Band band = bandOf(xi, config);
  const Footprint footprint(cad_in_cell, config.grid_cell, band.r_in, band.r_out + config.contour_radius);
  const PointGrid cad_grid(cad_in_cell, xi);
  const PosedPart part{footprint,        Eigen::Isometry2d::Identity(), bandBox(cad_in_cell, band.r_out), cad_grid,
                       Pose::Identity(), grown(bounds(cad_in_cell), xi)};

  // 4-6. Segmentation, band, H_pow, Eq. 2.
  if (!segmentAndEstimate(part, scan, xi, config, out, &out.part)) return out;

  // 7. The ordered contour: the band's centre line around the silhouette, at the local powder height.
  const Polyline2 loop = footprint.outerContour(0.5 * (band.r_in + band.r_out), config.contour_spacing);
  liftContour(loop, out.band, config.contour_radius, config.contour_min_points, out.h_pow, out.contour);
  return out;
}

EtaEstimator::EtaEstimator(Cloud cad_part, double xi, const ProgressConfig& config)
    : cad_(std::make_shared<const Cloud>(std::move(cad_part))), xi_(xi), config_(config) {}

ProgressEstimate EtaEstimator::estimate(const Pose& T_cell_part, const Cloud& scan) {
  ProgressEstimate out;
  reused_ = false;
  if (!T_cell_part.matrix().allFinite()) return fail(out, Status::kNoPose, "the pose contains NaN/inf");
  cad_in_cell_.resize(cad_ ? cad_->size() : 0);
  for (std::size_t i = 0; i < cad_in_cell_.size(); ++i) cad_in_cell_[i] = T_cell_part * (*cad_)[i];
  if (!checkInputsAndHeights(cad_in_cell_, scan, xi_, config_, out)) return out;
  if (grid_.size() == 0) {  // once: the samples do not move in the part frame
    grid_ = PointGrid(*cad_, xi_);
    near_box_ = grown(bounds(*cad_), xi_);
  }

  // 3. The footprint: the one built at an earlier pose if the projection has only turned about the
  // vertical and slid since (to within footprint_reuse), else a new one at this pose.
  const Band band = bandOf(xi_, config_);
  Eigen::Isometry2d to_footprint = Eigen::Isometry2d::Identity();
  reused_ = have_footprint_ && config_.footprint_reuse > 0 &&
            planarMotion(footprint_cad_, cad_in_cell_, (T_cell_part * T_footprint_.inverse()).linear(),
                         config_.footprint_reuse, to_footprint);
  if (!reused_) {
    footprint_ = Footprint(cad_in_cell_, config_.grid_cell, band.r_in, band.r_out + config_.contour_radius);
    footprint_cad_ = cad_in_cell_;
    band_box_ = bandBox(cad_in_cell_, band.r_out);
    T_footprint_ = T_cell_part;
    have_footprint_ = true;
    to_footprint = Eigen::Isometry2d::Identity();
  }
  const PosedPart part{footprint_, to_footprint, band_box_, grid_, T_cell_part.inverse(Eigen::Isometry), near_box_};

  // 4-6. The same segmentation, band, H_pow and Eq. 2 as estimateProgress.
  segmentAndEstimate(part, scan, xi_, config_, out, nullptr);
  return out;
}

}  // namespace depowder::progress
