#include "depowder/perception/camera_proxy.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "depowder/clock.hpp"

namespace depowder::perception {

std::int64_t ProxyCounters::dropped() const {
  return std::accumulate(by_status.begin() + 1, by_status.end(), std::int64_t{0});
}

namespace {

/// The tool at the nozzle's pose, as the self-filter removes it: the tube up from the tip and the
/// end effector's cylinders from the flange (effectorBodies), each grown by the margin.
class ToolVolume {
 public:
  ToolVolume(const SelfFilterConfig& sf, const Pose& T_cell_nozzle)
      : sf_(sf), T_nozzle_cell_(T_cell_nozzle.inverse(Eigen::Isometry)), in_nozzle_(grown(sf.radius, sf.length)) {
    const Pose T_nozzle_flange = sf.T_flange_nozzle.inverse(Eigen::Isometry);
    for (const EffectorBody& e : effectorBodies(sf.effector, sf.T_flange_nozzle)) {
      const Pose T_nozzle_end = T_nozzle_flange * e.T_flange_end();
      effector_.push_back({T_nozzle_end.inverse(Eigen::Isometry), e.radius, e.length});
      in_nozzle_.extend(bounds(grown(e.radius, e.length), T_nozzle_end));
    }
    in_cell_ = bounds(in_nozzle_, T_cell_nozzle);
  }

  bool contains(const Point& p_cell) const {
    // Most points are nowhere near the tool: outside the boxes that hold it all (in the cell
    // frame, then in the nozzle frame) they need no test of its parts.
    if (!in_cell_.contains(p_cell)) return false;
    const Point q = T_nozzle_cell_ * p_cell;
    if (!in_nozzle_.contains(q)) return false;
    return onNozzleBody(q, sf_.length, sf_.radius, sf_.margin, sf_.margin) ||
           std::any_of(effector_.begin(), effector_.end(), [&](const Body& e) {
             return onNozzleBody(e.T_end_nozzle * q, e.length, e.radius, sf_.margin, sf_.margin);
           });
  }

 private:
  /// A cylinder from its end at the origin, grown: its bounds in that end's frame.
  Eigen::AlignedBox3d grown(double radius, double length) const {
    const double r = radius + sf_.margin;
    return {Eigen::Vector3d(-r, -r, -length - sf_.margin), Eigen::Vector3d(r, r, sf_.margin)};
  }

  /// An end effector cylinder, tested from its end nearest the tip (as the tube from the tip).
  struct Body {
    Pose T_end_nozzle;
    double radius, length;
  };
  const SelfFilterConfig& sf_;
  Pose T_nozzle_cell_;  ///< nozzle frame: tip at the origin, body along -z (the spray direction is +z)
  Eigen::AlignedBox3d in_nozzle_, in_cell_;
  std::vector<Body> effector_;
};

}  // namespace

CameraProxy::CameraProxy(const PerceptionConfig& config, const Eigen::Vector3d& box_size,
                         std::vector<std::string> known_cameras)
    : config_(config),
      crop_(cropBox(box_size, config.crop_margin)),
      merger_(config.merger, std::move(known_cameras)),
      grid_(crop_, config.voxel_leaf),
      box_size_(box_size) {}

FrameError CameraProxy::nameError(const std::string& camera) const {
  if (camera.empty()) return {FrameStatus::kBadHeader, "a frame without a camera name"};
  if (merger_.knows(camera) || merger_.cameras() < kMaxCameras) return {};
  std::string names;
  for (const CameraHealth& h : merger_.health(0)) names += (names.empty() ? "" : ", ") + h.name;
  return {FrameStatus::kBadHeader, "camera '" + camera + "' would be camera " + std::to_string(kMaxCameras + 1) +
                                       ", past the " + std::to_string(kMaxCameras) + " taken (" + names +
                                       "): a mis-set camera name?"};
}

FrameError CameraProxy::addDepth(const DepthImage& image, const PinholeCamera& camera, std::int64_t arrival) {
  if (FrameError e = nameError(camera.name); !e.ok()) return reject(e), e;
  auto it = deprojectors_.find(camera.name);
  if (it == deprojectors_.end()) it = deprojectors_.emplace(camera.name, Deprojector(crop_)).first;
  Cloud storage;
  if (!spare_.empty()) {
    storage = std::move(spare_.back());
    spare_.pop_back();
  }
  const FrameError result = accept(it->second(image, camera, std::move(storage)), camera.name, image.utime, arrival);
  // A name the merger did not take (its frame refused) keeps no tables: the camera cap counts the
  // merger's cameras, and refused frames under ever new names once grew this map without bound.
  if (!merger_.knows(camera.name)) deprojectors_.erase(camera.name);
  return result;
}

FrameError CameraProxy::addCameraPoints(const Cloud& camera_points, std::int64_t utime, const PinholeCamera& camera,
                                        std::int64_t arrival) {
  if (FrameError e = nameError(camera.name); !e.ok()) return reject(e), e;
  return accept(cameraPointsToCell(camera_points, camera, crop_), camera.name, utime, arrival);
}

void CameraProxy::reject(const FrameError& error) {
  ++counters_.frames_in;
  ++counters_.by_status[static_cast<std::size_t>(error.status)];
  if (!error.ok()) counters_.last_error = error;
}

FrameError CameraProxy::accept(CameraCloud&& cloud, const std::string& camera, std::int64_t utime,
                               std::int64_t arrival) {
  FrameError result = cloud.error;
  if (result.ok() && !utimeInRange(utime))
    result = {FrameStatus::kBadHeader, "camera '" + camera + "': " + utimeOutOfRange(utime)};
  if (!result.ok() && merger_.knows(camera)) refused_[camera] = {arrival, result.message};
  if (result.ok()) result = merger_.add(CameraFrame{camera, utime, std::move(cloud.points)}, arrival);
  reject(result);
  return result;
}

std::vector<CameraHealth> CameraProxy::health(std::int64_t now) const {
  std::vector<CameraHealth> out = merger_.health(now);
  const auto silent_after = static_cast<std::int64_t>(config_.merger.silent_after * 1e6);
  for (CameraHealth& h : out)
    if (const auto it = refused_.find(h.name);
        h.silent && it != refused_.end() && now - it->second.first <= silent_after)
      h.refused = it->second.second;
  return out;
}

std::vector<CellCloud> CameraProxy::poll(std::int64_t now) {
  std::vector<CellCloud> out;
  for (MergedFrame& merged : merger_.poll(now)) out.push_back(finish(std::move(merged)));
  return out;
}

void CameraProxy::addNozzlePose(std::int64_t utime, const Pose& T_cell_nozzle) {
  if (!utimeInRange(utime)) return;
  // Far behind the newest: the clock went back (a log played again), start over.
  if (!nozzle_poses_.empty() && clockWentBack(nozzle_poses_.back().first, utime)) nozzle_poses_.clear();
  // Kept in time order, however they come: one stamped ahead of the others (a bad stamp) keeps
  // none of those after it out, and the oldest go first.
  const auto at = std::lower_bound(nozzle_poses_.begin(), nozzle_poses_.end(), utime,
                                   [](const auto& pose, std::int64_t u) { return pose.first < u; });
  if (at != nozzle_poses_.end() && at->first == utime) return;
  nozzle_poses_.emplace(at, utime, T_cell_nozzle);
  if (nozzle_poses_.size() > kNozzlePoses) nozzle_poses_.pop_front();
}

const Pose* CameraProxy::nozzleAt(std::int64_t utime) const {
  const Pose* best = nullptr;
  std::int64_t best_dt = static_cast<std::int64_t>(config_.self_filter.max_age * 1e6);
  for (const auto& [t, T] : nozzle_poses_) {
    const std::int64_t dt = t > utime ? t - utime : utime - t;
    if (dt <= best_dt) best_dt = dt, best = &T;
  }
  return best;
}

void CameraProxy::checkAgreement(const MergedFrame& merged) {
  const AgreementConfig& c = config_.agreement;
  const std::int64_t since = merged.utime - last_check_;  // < 0: the clock went back (a log played again)
  if (c.period <= 0 || merged.sources.size() < 2 || (since >= 0 && since < c.period * 1e6)) return;
  last_check_ = merged.utime;
  const CameraFrame& reference = merged.sources.front();
  for (std::size_t k = 1; k < merged.sources.size(); ++k) {
    CameraAgreement& a = agreement_[merged.sources[k].camera];
    a.reference = reference.camera;
    a.last = compareHeights(merged.sources[k].points, reference.points, box_size_, c);
    const bool over = a.last.valid && (std::abs(a.last.offset) > c.max_offset || a.last.tilt_deg > c.max_tilt_deg);
    a.over = over ? a.over + 1 : 0;  // a check without a figure (the powder hidden) ends a run too
    a.flagged = a.over >= c.flag_after;
  }
}

CellCloud CameraProxy::finish(MergedFrame&& merged) {
  CellCloud out;
  out.utime = merged.utime;
  out.missing = std::move(merged.missing);
  const Pose* nozzle = config_.self_filter.margin >= 0 ? nozzleAt(merged.utime) : nullptr;
  std::optional<ToolVolume> tool;
  if (nozzle) tool.emplace(config_.self_filter, *nozzle);
  out.unfiltered = config_.self_filter.margin >= 0 && !nozzle;
  // Sources are sorted by camera name, so the voxel order does not depend on arrival order.
  for (CameraFrame& f : merged.sources) {
    out.sources.push_back(f.camera);
    out.source_utimes.push_back(f.utime);
    out.points_in += f.points.size();
    if (tool) {
      const std::size_t before = f.points.size();
      f.points.erase(
          std::remove_if(f.points.begin(), f.points.end(), [&](const Point& p) { return tool->contains(p); }),
          f.points.end());
      out.on_nozzle += before - f.points.size();
    }
    grid_.add(f.points);
  }
  checkAgreement(merged);
  for (CameraFrame& f : merged.sources) {
    if (spare_.size() < 8) spare_.push_back(std::move(f.points));  // capacity reused by the next frames
  }
  VoxelGrid::Result voxels = grid_.extract(config_.outlier_min_neighbours);
  out.points = std::move(voxels.points);
  out.outliers = voxels.outliers;
  ++counters_.frames_out;
  if (!out.missing.empty()) ++counters_.partial_out;
  if (out.unfiltered) ++counters_.unfiltered_out;
  return out;
}

}  // namespace depowder::perception
