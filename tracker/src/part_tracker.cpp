#include "depowder/tracker/part_tracker.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "format.hpp"

namespace depowder::tracker {

using detail::fixed;

const char* toString(TrackStatus status) {
  switch (status) {
    case TrackStatus::kWaiting:
      return "waiting";
    case TrackStatus::kTracking:
      return "tracking";
    case TrackStatus::kDegraded:
      return "degraded";
    case TrackStatus::kLost:
      return "lost";
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The nearest-neighbour grids have cells of this many times their largest query radius: the same
// answers as cells of the radius, from fewer and fuller cells (depowder-bench: the scan's grid 7 %
// faster a frame, the template's 5 % more; tracker/README.md).
constexpr double kCellsOfRadii = 2;

}  // namespace

PartTracker::PartTracker(std::string name, const Mesh& mesh, const Pose& T_cell_part_init, double xi,
                         const TrackerConfig& config)
    : name_(std::move(name)), config_(config), xi_(xi), T_cell_part_init_(T_cell_part_init) {
  const std::string part = "part '" + name_ + "': ";
  if (const std::string why = validate(config_); !why.empty())
    throw std::invalid_argument(part + "tracker config: " + why);
  if (!(std::isfinite(xi_) && xi_ > 0)) throw std::invalid_argument(part + "xi must be > 0 m");
  if (!isValidPose(T_cell_part_init_, 1e-6))
    throw std::invalid_argument(part + "initial pose is not a rigid transform");
  if (mesh.triangles.empty()) throw std::invalid_argument(part + "mesh has no triangles");
  try {
    cad_ = sampleSurface(mesh, config_.cad_spacing);
  } catch (const MeshError& e) {
    throw std::invalid_argument(part + "cannot sample the mesh: " + e.what());
  }
  cad_box_ = bounds(cad_.points);
  // P_cad thinned to icp_leaf for Eq. 2: the same eta to about 1 % at a third of the cost.
  const Indices sparse = thinned(cad_.points, allIndices(cad_.points.size()), config_.icp_leaf);
  cad_sparse_points_ = gather(cad_.points, sparse);
  cad_sparse_normals_ = gather(cad_.normals, sparse);
  eta_estimator_ = progress::EtaEstimator(cad_sparse_points_, xi_, config_.progress);
  T_cell_part_ = T_cell_part_init_;
  last_update_ = {T_cell_part_init_, 0.0};
  resetInformation();
}

void PartTracker::resetInformation() {
  const double r = config_.filter.initial_deg * M_PI / 180, t = config_.filter.initial_m;
  information_.setZero();
  information_.diagonal() << Eigen::Vector3d::Constant(1 / (r * r)), Eigen::Vector3d::Constant(1 / (t * t));
}

// The filter's prediction for this frame: the part stays where it was, less sure by the process
// noise (cell axes: it turns about the vertical and slides, it seldom tips or sinks; a still part
// turns far less than a pushed one, and one that moved a little, a little more). With the fall
// gate on (FilterConfig::fall_tilt_deg), a part whose origin sinks fast may tip: it is falling.
Vector6d PartTracker::processVariance() const {
  const FilterConfig& f = config_.filter;
  const double yaw = f.q_yaw_deg * M_PI / 180;
  const double tilt = (falling_ ? std::max(f.q_tilt_deg, f.fall_tilt_deg) : f.q_tilt_deg) * M_PI / 180;
  Vector6d q;
  q << tilt * tilt, tilt * tilt, yaw * yaw, f.q_xy * f.q_xy, f.q_xy * f.q_xy, f.q_z * f.q_z;
  return q;
}

PosePrior PartTracker::predicted() const {
  const FilterConfig& f = config_.filter;
  Vector6d q = processVariance();
  const double turn = falling_ ? 1 : f.still_turn + (1 - f.still_turn) * turn_open_;
  q.head<3>() *= turn * turn;
  q *= periods_;  // a random walk: its variance grows with the frame periods since the last fit
  // The part turns about the middle of what the cameras see of it, not about its origin: in
  // PosePrior's coordinates a turn w about c also moves the origin by w x (t - c).
  Matrix6d M = Matrix6d::Identity();
  if (!visible_points_.empty()) {
    Point centre = Point::Zero();
    for (const Point& p : visible_points_) centre += p;
    const Eigen::Vector3d arm = T_cell_part_.linear() * (-centre / static_cast<double>(visible_points_.size()));
    for (int k = 0; k < 3; ++k) M.block<3, 1>(3, k) = Eigen::Vector3d::Unit(k).cross(arm);  // t - c
  }
  Matrix6d covariance = information_.inverse();
  covariance += M * q.asDiagonal() * M.transpose();
  PosePrior prior;
  prior.T_cell_part = T_cell_part_;
  prior.information = covariance.inverse();
  prior.information = 0.5 * (prior.information + prior.information.transpose());
  prior.inflation = f.data_inflation;
  return prior;
}

// The disagreement check. The fit without the filter differs from the filter's (PosePrior's
// coordinates); over reset_frames frames in a row the mean difference is tested twice:
// - against both fits' uncertainties (the filter's prior and the free fit's information, counted
//   as the filter counts it): a still tube's spin, unseen by the scan and held by the filter, is
//   no disagreement;
// - by what it asks of the pose in the ways a pushed part moves (weighed by what the scan sees
//   against reset_frames frames of a pushed part's process noise: a tip is not asked for).
// Both beyond their limits, and the free fits explaining the scan about as well as the filter's
// over those frames (their mean inlier ratio at most reset_inlier_margin lower), and the move asked
// explaining most of the difference (what it leaves at most reset_unexplained of its chi-square), the filter
// starts again from its pose moved as this frame asks. (At the end of a push, the part against
// the box wall, free fits disagreed with the filter while matching 0.60-0.67 of the template
// points against its fit's 0.65-0.83, and a restart from them lost the cube: Table II, seed 2.
// An owl whose estimate spun 13 deg away as it slid was held there, with no margin, by free fits
// matching 0.7 to 1.6 % fewer.)
bool PartTracker::restartFilter(const RegistrationResult& filtered, const RegistrationResult& free,
                                const Matrix6d& prior_information) {
  const FilterConfig& f = config_.filter;
  const StatusConfig& s = config_.status;
  if (!free.ok() || !isValidPose(free.T_target_source, 1e-6) || free.inlier_ratio < s.tracking_min_inlier_ratio ||
      free.rms > s.tracking_max_rms) {
    disagreements_.clear();  // a doubtful free fit says nothing, and the mean starts again...
    fits_disagreed_ = true;  // ...nor that the fits agree: the next frame is checked too
    return false;
  }
  const Vector6d difference = deviation(free.T_target_source, filtered.T_target_source);
  fits_disagreed_ =
      !(difference.head<3>().norm() * 180 / M_PI <= f.reset_deg / 2 && difference.tail<3>().norm() <= f.reset_m);
  disagreements_.push_back({difference, free.inlier_ratio - filtered.inlier_ratio, unchecked_periods_});
  if (disagreements_.size() > static_cast<std::size_t>(f.reset_frames)) disagreements_.pop_front();
  if (disagreements_.size() < static_cast<std::size_t>(f.reset_frames)) return false;
  const double n = static_cast<double>(disagreements_.size());
  Vector6d mean = Vector6d::Zero();
  double inlier_gain = 0, periods = 0;
  for (const Disagreement& d : disagreements_) {
    mean += d.difference / n;
    inlier_gain += d.inlier_gain / n;
    periods += d.periods;
  }
  if (inlier_gain < -f.reset_inlier_margin) return false;

  const Matrix6d seen = free.information / f.data_inflation;
  // A half-turn and a metre of uncertainty keep an unseen direction's inverse finite.
  Vector6d vague;
  vague << Eigen::Vector3d::Constant(1 / (M_PI * M_PI)), Eigen::Vector3d::Constant(1.0);
  const Matrix6d uncertainty = prior_information.inverse() + (seen + Matrix6d(vague.asDiagonal())).inverse();
  const Eigen::LDLT<Matrix6d> within(uncertainty);
  const double chi2 = n * mean.dot(within.solve(mean));
  const Vector6d motion = periods * periods * processVariance();  // over the periods the checks span
  const Matrix6d loose = motion.cwiseInverse().asDiagonal();
  const Eigen::LDLT<Matrix6d> ask(loose + seen);
  const Vector6d asked_mean = ask.solve(seen * mean);
  if (chi2 <= f.reset_chi2 ||
      (asked_mean.head<3>().norm() * 180 / M_PI <= f.reset_deg && asked_mean.tail<3>().norm() <= f.reset_m))
    return false;
  // What the move asked leaves of the difference: a part the filter held still while it was pushed
  // leaves little (the restarts that brought Table II's pushes back, 1 to 9 % of the chi-square); a
  // biased free fit disagrees in ways no push moves the part and leaves most (a cube against the box
  // wall, mostly buried, free fits 20 deg off in tilt: 80 to 98 %).
  const Vector6d unexplained = mean - asked_mean;
  if (n * unexplained.dot(within.solve(unexplained)) > f.reset_unexplained * chi2) return false;
  T_cell_part_ = moved(filtered.T_target_source, ask.solve(seen * difference));
  information_ = loose + seen;
  disagreements_.clear();
  return true;
}

double PartTracker::correspondenceDistance() const {
  return config_.icp.max_correspondence_distance > 0 ? config_.icp.max_correspondence_distance : xi_;
}

double PartTracker::estimateEta(const Pose& T_cell_part, const Cloud& scan, std::string* why) {
  // Alg. 1, line 11: eta_i from P_cad . T_i and P_i, with the Eq. 2 code the progress process runs
  // (without the contour, which only the planner needs).
  const progress::ProgressEstimate e = eta_estimator_.estimate(T_cell_part, scan);
  // The band's powder also tells the next frame which template points are under the powder.
  if (e.status == progress::Status::kOk && config_.visibility.powder_radius > 0)
    powder_ = PowderHeights(e.band, e.h_pow, config_.visibility.powder_radius);
  if (e.status != progress::Status::kOk) {
    if (why) *why = std::string("progress unavailable (") + progress::toString(e.status) + ": " + e.reason + ")";
    return std::nan("");
  }
  return e.eta;
}

void PartTracker::setTemplate(Indices indices) {
  template_ = std::move(indices);
  const Indices icp = thinned(cad_.points, template_, config_.icp_leaf);
  icp_points_ = gather(cad_.points, icp);
  icp_normals_ = gather(cad_.normals, icp);
  ++template_version_;
}

TrackResult PartTracker::refuse(TrackResult r, std::string why) const {
  r.status = started_ ? TrackStatus::kLost : TrackStatus::kWaiting;
  r.reason = std::move(why) + (started_ ? "; last good pose kept" : "; initial pose kept");
  r.T_cell_part = T_cell_part_;
  return r;
}

void PartTracker::placeSparse(const Pose& T_cell_part) {
  sight_points_.resize(cad_sparse_points_.size());
  sight_normals_.resize(cad_sparse_points_.size());
  for (std::size_t i = 0; i < cad_sparse_points_.size(); ++i) {
    sight_points_[i] = T_cell_part * cad_sparse_points_[i];
    sight_normals_[i] = T_cell_part.linear() * cad_sparse_normals_[i];
  }
}

// How well P_cad at a pose explains the scan: its samples within xi of a scan point, less twice
// those the cameras saw through (in front of the scanned surface).
int PartTracker::sightScore(const Pose& T_cell_part, const SightImages& images, const ScanIndex& grid) {
  placeSparse(T_cell_part);
  const SightCheck c = images.check(sight_points_, sight_normals_, xi_, &verdict_);
  int near = 0;
  for (const Point& p : sight_points_) near += grid.nearest(p, xi_).found();
  return near - 2 * c.in_front;
}

bool PartTracker::refit(const SightImages& images, const Surface& scan, double max_distance) {
  const ScanIndex& grid = scan.index;
  const int tracked = sightScore(T_cell_part_, images, grid);  // fills verdict_ at the tracked pose
  // The source: the samples the cameras should see at the tracked pose (on the scanned surface
  // or in front of it), not those behind powder.
  refit_points_.clear();
  refit_normals_.clear();
  for (std::size_t i = 0; i < verdict_.size(); ++i)
    if (verdict_[i] == SightCheck::kSeen || verdict_[i] == SightCheck::kInFront) {
      refit_points_.push_back(cad_sparse_points_[i]);
      refit_normals_.push_back(cad_sparse_normals_[i]);
    }
  if (refit_points_.size() < static_cast<std::size_t>(config_.icp.min_correspondences)) return false;
  const ScanIndex refit_index(refit_points_, kCellsOfRadii * max_distance);
  const RegistrationResult reg =
      registerSurfaces({refit_points_, refit_normals_, refit_index}, scan, T_cell_part_, max_distance, config_.icp);
  if (!reg.ok() || !isValidPose(reg.T_target_source, 1e-6)) return false;
  const int refitted = sightScore(reg.T_target_source, images, grid);
  if (refitted <= tracked + config_.refit_margin * static_cast<double>(cad_sparse_points_.size())) return false;
  if (rotationDistanceDeg(reg.T_target_source, T_cell_part_) < config_.refit_min_rotation_deg &&
      translationDistance(reg.T_target_source, T_cell_part_) < xi_)
    return false;  // a small correction is ICP's business (its filter weighs it against the noise)
  T_cell_part_ = reg.T_target_source;
  return true;
}

void PartTracker::updateMotionState(double periods) {
  // Still or moving: how far the part went over the last moving_frames frame periods (the poses
  // tracked since, and the one before them). A turn opens the turn noise; a slide opens it from
  // the threshold to moving_full times it.
  const FilterConfig& f = config_.filter;
  recent_.push_back({T_cell_part_, periods});
  double span = 0;  // periods from the first pose kept to the last
  for (std::size_t k = 1; k < recent_.size(); ++k) span += recent_[k].periods;
  while (recent_.size() > 1 && span - recent_[1].periods >= f.moving_frames) {
    span -= recent_[1].periods;
    recent_.pop_front();
  }
  const Pose& from = recent_.front().T_cell_part;
  const double slide = translationDistance(from, T_cell_part_);
  const bool turned = rotationDistanceDeg(from, T_cell_part_) > f.moving_rotation_deg;
  moving_ = turned || slide > f.moving_translation;
  falling_ = f.fall_tilt_deg > 0 && from.translation().z() - T_cell_part_.translation().z() > f.fall_sink;
  const double full = f.moving_full * f.moving_translation;
  turn_open_ = !moving_                  ? 0
               : turned || slide >= full ? 1
                                         : (slide - f.moving_translation) / (full - f.moving_translation);
}

TrackResult PartTracker::track(const Cloud& scan) { return track(scan, config_.viewpoints); }

void PartTracker::elapse(double periods) {
  if (!std::isfinite(periods))
    throw std::invalid_argument("part '" + name_ + "': elapsed frame periods must be finite, not " +
                                std::to_string(periods));
  next_periods_ = std::max(1.0, periods);
}

void PartTracker::predictMotion(const Pose& delta) {
  if (!delta.matrix().allFinite() || !isValidPose(delta, 1e-6))
    throw std::invalid_argument("part '" + name_ + "': a predicted motion must be a finite rigid transform");
  predicted_motion_ = delta * predicted_motion_;
}

TrackResult PartTracker::track(const Cloud& scan, const std::vector<Point>& viewpoints) {
  const Clock::time_point t_start = Clock::now();
  T_cell_part_ = predicted_motion_ * T_cell_part_;  // predictMotion's (the identity leaves it bit for bit)
  if (!started_) T_cell_part_init_ = T_cell_part_;  // the same pose until Phase 1 ends
  predicted_motion_ = Pose::Identity();
  periods_ += next_periods_;  // the filter's process noise covers the time since its last fit
  unchecked_periods_ += next_periods_;
  next_periods_ = 1;
  TrackResult r;
  r.T_cell_part = T_cell_part_;
  r.eta = eta_;
  auto finish = [&](TrackResult out) {
    out.template_version = template_version_;
    out.template_size = template_.size();
    out.timing.total_ms = msSince(t_start);
    return out;
  };

  // Alg. 1, line 2: P_i, cropped to the part's neighbourhood at the predicted pose T_{i-1}
  // (the authors crop +-12 cm); a grid on the crop serves both ICP and Alg. 2.
  if (scan.empty()) return finish(refuse(r, "empty scan"));
  Clock::time_point t0 = Clock::now();
  const std::size_t non_finite = cropToPart(scan, T_cell_part_, cad_box_, config_.crop_margin, crop_);
  if (non_finite > 0)
    return finish(refuse(r, std::to_string(non_finite) + " of " + std::to_string(scan.size()) +
                                " scan points are NaN or infinite: frame refused"));
  if (crop_.size() < static_cast<std::size_t>(config_.min_scan_points))
    return finish(refuse(r, "only " + std::to_string(crop_.size()) + " scan points within " +
                                fixed(config_.crop_margin * 100, 1) + " cm of the part (need " +
                                std::to_string(config_.min_scan_points) + ")"));
  const double max_distance = correspondenceDistance();
  const ScanIndex grid(crop_, kCellsOfRadii * std::max(max_distance, xi_));
  r.timing.crop_ms = msSince(t0);

  // Phase 1 (Sec. III-B): while eta <= eta1 no tracking; the initial pose is reported.
  if (!started_) {
    t0 = Clock::now();
    std::string why;
    const double eta = estimateEta(T_cell_part_init_, crop_, &why);
    r.timing.progress_ms = msSince(t0);
    if (std::isnan(eta) || eta <= config_.eta1) {
      periods_ = unchecked_periods_ = 0;  // the filter starts with the first fit, from the initial pose's uncertainty
      r.status = TrackStatus::kWaiting;
      if (!std::isnan(eta)) eta_ = r.eta = eta;
      r.reason = std::isnan(eta) ? "phase 1: " + why
                                 : "phase 1: eta " + fixed(eta) + " <= eta1 " + fixed(config_.eta1) + ", no ICP";
      return finish(r);
    }
    // Alg. 1, lines 3-6: first iteration. T_i = T_init, P_cad at T_init, template by Alg. 2.
    started_ = true;
    eta_ = r.eta = eta;
    t0 = Clock::now();
    setTemplate(config_.method == Method::kVanilla ? allIndices(cad_.points.size())
                                                   : deriveTemplate(cad_.points, T_cell_part_, grid, xi_));
    r.timing.template_ms += msSince(t0);
    last_update_ = {T_cell_part_, eta_};
    r.template_updated = true;
  }
  // A template too small to register (the part was out of view when it was derived) is
  // re-derived before ICP, in every method: otherwise Eq. 1 could never fire again. Vanilla's is
  // the whole model, set here for a part resumed after a restart (it skipped lines 3-6).
  if (icp_points_.size() < static_cast<std::size_t>(config_.icp.min_correspondences)) {
    t0 = Clock::now();
    setTemplate(config_.method == Method::kVanilla ? allIndices(cad_.points.size())
                                                   : deriveTemplate(cad_.points, T_cell_part_, grid, xi_));
    r.timing.template_ms += msSince(t0);
    last_update_ = {T_cell_part_, eta_};
    r.template_updated = true;
  }

  // Alg. 1, lines 8-9: ICP(P_tmpl, P_i) with T_{i-1} as the prior. Registering the part-frame
  // template from T_{i-1} gives T_i = T_{i,i-1} x T_{i-1} directly. ICP uses the template points
  // the cameras can see now: facing one of them, not under the powder around the part, and no
  // upward face with powder straight over it.
  t0 = Clock::now();
  visibleTemplate(icp_points_, icp_normals_, T_cell_part_, viewpoints, powder_, config_.visibility.powder_margin, &grid,
                  config_.visibility.cover, visible_points_, visible_normals_);
  if (visible_points_.empty()) return finish(refuse(r, "no template point faces a camera above the powder"));
  const ScanIndex model_index(visible_points_, kCellsOfRadii * max_distance);
  // Normals only where ICP can use them: scan points in the template's grid cells or next to them,
  // cells of the correspondence distance (the pose moves little within a frame).
  const ScanIndex near_index(visible_points_, max_distance);
  const Pose T_part_cell = T_cell_part_.inverse(Eigen::Isometry);
  near_template_.resize(crop_.size());
  for (std::size_t j = 0; j < crop_.size(); ++j)
    near_template_[j] = near_index.anyInNeighbourCells(T_part_cell * crop_[j]);
  crop_normals_ = scanNormals(grid, viewpoints, config_.icp.normal_radius, near_template_);
  // Not in the paper: while the part is still, an upward-facing scan point at the level of the
  // powder around it is taken for powder. Template points still pair with it (their own powder
  // test decides), but it does not pull the template: every powder point over a face buried a few
  // mm deep would draw it up (in the default cell the pipe rose 1 cm while the vacuum lowered the
  // powder beside it). A pushed part's own faces near the powder are needed to follow it.
  scan_pulls_.assign(crop_.size(), 1);
  if (!powder_.empty() && config_.visibility.powder_scan_margin > 0 && !moving_)
    for (std::size_t j = 0; j < crop_.size(); ++j)
      if (facesUp(crop_normals_[j]) &&
          crop_[j].z() < powder_.at(crop_[j].head<2>()) + config_.visibility.powder_scan_margin)
        scan_pulls_[j] = 0;
  const Surface scan_surface{crop_, crop_normals_, grid, &scan_pulls_};
  const bool filter = config_.filter.data_inflation > 0;
  const PosePrior prior = filter ? predicted() : PosePrior{};
  FirstMatches first;  // the check's fit below starts where this one does
  const RegistrationResult reg =
      registerSurfaces({visible_points_, visible_normals_, model_index}, scan_surface, T_cell_part_, max_distance,
                       config_.icp, filter ? &prior : nullptr, &first);
  r.timing.icp_ms = msSince(t0);
  r.iterations = reg.iterations;
  r.fitness = reg.rms;
  r.inlier_ratio = reg.inlier_ratio;

  // Is the fit believable? The same rule for every method.
  const StatusConfig& s = config_.status;
  if (!reg.ok()) return finish(refuse(r, std::string("ICP failed: ") + reg.reason));
  if (!isValidPose(reg.T_target_source, 1e-6)) return finish(refuse(r, "ICP returned an invalid pose"));
  if (reg.inlier_ratio < s.lost_min_inlier_ratio)
    return finish(
        refuse(r, "fit refused: inlier ratio " + fixed(reg.inlier_ratio) + " < " + fixed(s.lost_min_inlier_ratio)));
  if (reg.rms > s.lost_max_rms)
    return finish(refuse(
        r, "fit refused: residual " + fixed(reg.rms * 1000, 1) + " mm > " + fixed(s.lost_max_rms * 1000, 1) + " mm"));
  // Not in the paper: the disagreement check (FilterConfig::reset_frames), the same scan
  // registered without the filter. A filter that holds a pushed part still never sees it move.
  // A still part whose two fits agreed is checked (and refitted, below) every check_every-th
  // frame only.
  bool reset = false;
  const FilterConfig& fc = config_.filter;
  const bool checking = filter && fc.reset_frames > 0;
  const bool due = !checking || moving_ || fits_disagreed_ || ++unchecked_frames_ >= fc.check_every;
  if (checking && due) {
    unchecked_frames_ = 0;
    t0 = Clock::now();
    const RegistrationResult free = registerSurfaces({visible_points_, visible_normals_, model_index}, scan_surface,
                                                     T_cell_part_, max_distance, config_.icp, nullptr, &first);
    reset = restartFilter(reg, free, prior.information);
    unchecked_periods_ = 0;
    r.checked = true;
    r.reset = reset;
    r.timing.check_ms = msSince(t0);
  }
  if (!reset) T_cell_part_ = reg.T_target_source;
  if (filter) {
    if (!reset) information_ = prior.information + reg.information / config_.filter.data_inflation;
    updateMotionState(periods_);
    periods_ = 0;
  }
  r.moving = moving_;
  r.falling = falling_;
  r.T_cell_part = T_cell_part_;
  r.status = TrackStatus::kTracking;
  if (reg.inlier_ratio < s.tracking_min_inlier_ratio) {
    r.status = TrackStatus::kDegraded;
    r.reason = "inlier ratio " + fixed(reg.inlier_ratio) + " < " + fixed(s.tracking_min_inlier_ratio);
  } else if (reg.rms > s.tracking_max_rms) {
    r.status = TrackStatus::kDegraded;
    r.reason = "residual " + fixed(reg.rms * 1000, 1) + " mm > " + fixed(s.tracking_max_rms * 1000, 1) + " mm";
  }

  // Not in the paper: the refit (sight.hpp). The filter keeps a still part's weakly seen motions
  // at the last pose; after a fast motion (a fall) it can keep a wrong one, and a template derived
  // there lacks the points that would correct it. So the whole CAD model is judged against the
  // cameras' lines of sight, fitted once more from the points the cameras should see without the
  // filter, and that fit replaces ICP's when it explains the scan better by refit_margin. It runs
  // on the frames the check is due: every frame of a fall (the part moves), every check_every-th
  // while a still part's fits agree.
  bool refitted = false;
  if (due && !viewpoints.empty() && config_.refit_margin > 0 && eta_ >= config_.refit_min_eta) {
    t0 = Clock::now();
    Eigen::AlignedBox3d region = bounds(cad_box_, T_cell_part_);  // the crop's box, cell frame
    region.min().array() -= config_.crop_margin;
    region.max().array() += config_.crop_margin;
    const SightImages images(scan, viewpoints, region);
    if (refit(images, scan_surface, max_distance)) {
      resetInformation();  // what the filter knew was about the wrong pose
      refitted = true;
      r.refit = true;
      r.T_cell_part = T_cell_part_;
    }
    placeSparse(T_cell_part_);
    r.sight = images.check(sight_points_, sight_normals_, xi_);
    r.timing.sight_ms = msSince(t0);
  }

  // Lines 10-11: P_cad moves with the pose; eta_i from Eq. 2 (kept from before if unavailable).
  t0 = Clock::now();
  std::string why;
  if (const double eta = estimateEta(T_cell_part_, crop_, &why); !std::isnan(eta)) eta_ = eta;
  r.eta = eta_;
  r.timing.progress_ms += msSince(t0);

  // Lines 12-16: the update policy, the one place the three methods differ. A doubtful fit
  // (DEGRADED: the part mostly occluded, e.g. by the nozzle) does not re-derive the template, in
  // any method: Alg. 2 at a wrong pose would lock the error in.
  r.update = decideTemplateUpdate(config_.method, T_cell_part_, eta_, last_update_, thresholdsOf(config_));
  // After a refit the template, derived at the wrong pose, is derived again (Vanilla has none),
  // also on a frame whose ICP fit was doubtful: the refit replaced that fit, explaining the scan
  // better.
  if (refitted && config_.method != Method::kVanilla) r.update.update = true;
  if (r.update.update && (r.status == TrackStatus::kTracking || refitted)) {
    t0 = Clock::now();
    setTemplate(deriveTemplate(cad_.points, T_cell_part_, grid, xi_));  // line 13, Alg. 2
    r.timing.template_ms += msSince(t0);
    last_update_ = {T_cell_part_, eta_};  // lines 14-16
    r.template_updated = true;
  }
  return finish(r);
}

}  // namespace depowder::tracker
