#include "tracker_node.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "depowder/clock.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/convert.hpp"
#include "progress_node.hpp"

namespace depowder::tracker {

TrackerNodeOptions readTrackerOptions(const node::CellConfig& cell) {
  TrackerNodeOptions o;
  TrackerConfig& c = o.tracker;
  const node::YamlReader r = cell.root.child("tracker");
  std::string method = toString(c.method);
  r.readChoice("method", method, {"cu", "continuous", "vanilla"});
  c.method = *methodFromString(method);
  r.read("delta1_deg", c.delta1_deg, 1e-6, 180.0);
  r.read("delta2", c.delta2, 1e-6, 10.0);
  r.read("delta3", c.delta3, 1e-6, 1.0);
  r.read("cad_spacing", c.cad_spacing, 0.0005, 0.02);
  r.read("icp_leaf", c.icp_leaf, 0.0, 0.05);
  r.read("crop_margin", c.crop_margin, 0.0, 0.5);
  r.read("min_scan_points", c.min_scan_points, 1, 1000000);
  r.read("refit_margin", c.refit_margin, 0.0, 1.0);
  r.read("refit_min_eta", c.refit_min_eta, 0.0, 1.0);
  r.read("refit_min_rotation_deg", c.refit_min_rotation_deg, 0.0, 180.0);
  r.read("cull_with_cameras", o.cull_with_cameras);
  r.read("threads", o.threads, 0, 256);
  r.read("template_leaf", o.template_leaf, 0.0, 0.05);
  r.read("template_resolution", o.template_resolution, 1e-5, 0.01);
  r.read("heartbeat_period", o.heartbeat_period, 0.05, 10.0);
  r.read("state_file", o.state_file);
  r.read("state_period", o.state_period, 0.01, 60.0);
  const node::YamlReader icp = r.child("icp");
  icp.read("max_iterations", c.icp.max_iterations, 1, 1000);
  icp.read("max_correspondence_distance", c.icp.max_correspondence_distance, 0.0, 0.5);
  icp.read("convergence_translation", c.icp.convergence_translation, 0.0, 0.01);
  icp.read("convergence_rotation", c.icp.convergence_rotation, 0.0, 0.1);
  icp.read("kernel_scale", c.icp.kernel_scale, 0.0, 0.1);
  icp.read("normal_min_cos", c.icp.normal_min_cos, -1.0, 1.0);
  icp.read("normal_radius", c.icp.normal_radius, 1e-4, 0.1);
  icp.read("tangent_weight", c.icp.tangent_weight, 0.0, 1.0);
  icp.read("scan_weight", c.icp.scan_weight, 0.0, 1.0);
  icp.read("max_step_rotation", c.icp.max_step_rotation, 1e-4, 3.2);
  icp.read("min_correspondences", c.icp.min_correspondences, 6, 1000000);
  icp.read("reassociate", c.icp.reassociate, 0.0, 0.05);
  icp.finish();
  const node::YamlReader visibility = r.child("visibility");
  visibility.read("powder_radius", c.visibility.powder_radius, 0.0, 0.2);
  visibility.read("powder_margin", c.visibility.powder_margin, -0.05, 0.05);
  visibility.read("cover", c.visibility.cover, 0.0, 0.02);
  visibility.read("powder_scan_margin", c.visibility.powder_scan_margin, 0.0, 0.05);
  visibility.finish();
  const node::YamlReader filter = r.child("filter");
  filter.read("data_inflation", c.filter.data_inflation, 0.0, 1e6);
  filter.read("q_yaw_deg", c.filter.q_yaw_deg, 1e-6, 90.0);
  filter.read("q_tilt_deg", c.filter.q_tilt_deg, 1e-6, 90.0);
  filter.read("q_xy", c.filter.q_xy, 1e-7, 1.0);
  filter.read("q_z", c.filter.q_z, 1e-7, 1.0);
  filter.read("still_turn", c.filter.still_turn, 1e-6, 1.0);
  filter.read("moving_translation", c.filter.moving_translation, 0.0, 1.0);
  filter.read("moving_rotation_deg", c.filter.moving_rotation_deg, 0.0, 180.0);
  filter.read("moving_frames", c.filter.moving_frames, 1, 1000);
  filter.read("moving_full", c.filter.moving_full, 1.0, 100.0);
  filter.read("fall_sink", c.filter.fall_sink, 1e-6, 1.0);
  filter.read("fall_tilt_deg", c.filter.fall_tilt_deg, 0.0, 90.0);
  filter.read("initial_deg", c.filter.initial_deg, 1e-6, 180.0);
  filter.read("initial_m", c.filter.initial_m, 1e-7, 1.0);
  filter.read("reset_chi2", c.filter.reset_chi2, 1e-6, 1e9);
  filter.read("reset_deg", c.filter.reset_deg, 1e-6, 180.0);
  filter.read("reset_m", c.filter.reset_m, 1e-7, 1.0);
  filter.read("reset_frames", c.filter.reset_frames, 0, 1000);
  filter.read("check_every", c.filter.check_every, 1, 1000);
  filter.read("reset_inlier_margin", c.filter.reset_inlier_margin, 0.0, 1.0);
  filter.read("reset_unexplained", c.filter.reset_unexplained, 0.0, 1.0);
  filter.finish();
  const node::YamlReader st = r.child("status");
  st.read("tracking_min_inlier_ratio", c.status.tracking_min_inlier_ratio, 0.0, 1.0);
  st.read("tracking_max_rms", c.status.tracking_max_rms, 1e-6, 0.1);
  st.read("lost_min_inlier_ratio", c.status.lost_min_inlier_ratio, 0.0, 1.0);
  st.read("lost_max_rms", c.status.lost_max_rms, 1e-6, 0.1);
  st.finish();
  r.finish();
  if (const std::string why = validate(c); !why.empty()) throw node::ConfigError(cell.file + ": tracker: " + why);

  // Phase 1 and Eq. 2 exactly as depowder-progress has them.
  c.progress = progress::readProgressOptions(cell).estimator;
  c.eta1 = c.progress.eta1;
  if (o.cull_with_cameras)
    for (const node::CameraConfig& cam : cell.cameras) c.viewpoints.push_back(cam.T_cell_camera.translation());
  return o;
}

TrackerNode::TrackerNode(const node::CellConfig& cell, const TrackerNodeOptions& options,
                         const std::map<std::string, SavedPose>& resume)
    : options_(options) {
  std::vector<PartTracker> parts;
  for (const node::PartConfig& p : cell.parts) {
    const auto saved = resume.find(p.name);  // a saved part the cell no longer has is dropped
    if (saved != resume.end()) last_poses_[p.name] = saved->second;
    const Pose& T_init = saved != resume.end() ? saved->second.T_cell_part : p.T_cell_part_init;
    parts.emplace_back(p.name, node::loadPartMesh(p), T_init, p.xi, options_.tracker);
    if (saved != resume.end()) parts.back().resume();  // only parts past Phase 1 are saved
  }
  trackers_ = std::make_unique<MultiTracker>(std::move(parts), options_.threads);
  for (const node::CameraConfig& cam : cell.cameras) {
    camera_names_.insert(cam.name);
    if (options_.cull_with_cameras) cameras_[cam.name] = cam.T_cell_camera.translation();
  }
  for (const node::CameraConfig& cam : cell.cameras) frame_rate_ = std::max(frame_rate_, cam.rate_hz);
  published_version_.assign(trackers_->size(), -1);
  encoded_.resize(trackers_->size());
}

std::vector<std::string> TrackerNode::partNames() const {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < trackers_->size(); ++i) names.push_back(trackers_->part(i).name());
  return names;
}

part_pose_t TrackerNode::toMessage(std::int64_t utime, std::size_t i, const TrackResult& r) {
  const PartTracker& part = trackers_->part(i);
  part_pose_t m;
  m.utime = utime;
  m.part = part.name();
  m.method = toString(part.method());
  switch (r.status) {
    case TrackStatus::kWaiting:
      m.status = part_pose_t::WAITING;
      break;
    case TrackStatus::kTracking:
      m.status = part_pose_t::TRACKING;
      break;
    case TrackStatus::kDegraded:
      m.status = part_pose_t::DEGRADED;
      break;
    case TrackStatus::kLost:
      m.status = part_pose_t::LOST;
      break;
  }
  m.status_reason = r.reason;
  m.T_cell_part = node::toMsg(r.T_cell_part);  // PartTracker never reports an invalid pose
  m.eta = r.eta;
  m.fitness = r.fitness;
  m.inlier_ratio = r.inlier_ratio;
  m.iterations = r.iterations;
  m.compute_ms = static_cast<float>(r.timing.total_ms);
  m.template_updated = r.template_updated;
  m.template_version = part.templateVersion();
  m.template_resolution = static_cast<float>(options_.template_resolution);
  // The template in the part frame, quantised (re-encoded only when it changed).
  if (published_version_[i] != part.templateVersion()) {
    auto& out = encoded_[i];
    out.clear();
    const Indices shown = thinned(part.cad().points, part.templateIndices(), options_.template_leaf);
    const double limit = std::numeric_limits<std::int16_t>::max();
    for (const std::uint32_t k : shown) {
      const Eigen::Vector3d q = (part.cad().points[k] / options_.template_resolution).array().round();
      if (q.cwiseAbs().maxCoeff() > limit) continue;  // beyond +-16 m at 0.5 mm: not a part
      out.push_back(
          {static_cast<std::int16_t>(q.x()), static_cast<std::int16_t>(q.y()), static_cast<std::int16_t>(q.z())});
    }
    published_version_[i] = part.templateVersion();
  }
  m.template_xyz = encoded_[i];
  m.template_size = static_cast<std::int32_t>(m.template_xyz.size());
  return m;
}

std::string TrackerNode::refusedStamp(std::int64_t utime, std::int64_t arrival) {
  if (!utimeInRange(utime)) return utimeOutOfRange(utime);
  if (newest_utime_ >= 0) {
    if (const std::int64_t ahead = runsAhead(newest_utime_, newest_arrival_, utime, arrival); ahead > kClockJumpBack) {
      if (!ahead_.confirms(utime, arrival)) {
        char seconds[32];
        std::snprintf(seconds, sizeof seconds, "%.1f", static_cast<double>(ahead) * 1e-6);
        return "utime " + std::to_string(utime) + ", " + seconds + " s ahead of the frame tracked last (utime " +
               std::to_string(newest_utime_) +
               ") and the time since: a bad stamp, unless the next frame runs with it (the cameras' clock jumped "
               "forward)";
      }
      ++stats_.clock_restarts;  // the cameras' clock jumped forward: tracked on from the last poses
      tracked_utime_ = -1;      // no time to tell the filters
    } else {
      ahead_.forget();
      if (utime <= newest_utime_) {
        if (!clockWentBack(newest_utime_, utime))
          return "utime " + std::to_string(utime) + ", not newer than the frame tracked last (utime " +
                 std::to_string(newest_utime_) + "): reordered, or a second camera proxy publishes POINTS";
        // Far behind is the clock going back, taken at once: the camera proxy has refused a lone
        // frame far behind already (a bad stamp), and waiting for a second here would lose one
        // more frame of every real step (a log played again, the proxy restarted).
        ++stats_.clock_restarts;  // tracked on from the last poses
      }
    }
  }
  newest_utime_ = utime;
  newest_arrival_ = arrival;
  return "";
}

std::vector<part_pose_t> TrackerNode::onPoints(const point_cloud_t& msg, std::int64_t arrival) {
  const auto t0 = std::chrono::steady_clock::now();
  ++stats_.frames;
  std::vector<part_pose_t> out;
  if (const std::string refused = refusedStamp(msg.utime, arrival); !refused.empty()) {
    ++stats_.refused_frames;
    stats_.last_problem = "POINTS at " + refused + ": not tracked";
    return out;
  }
  std::string why;
  const std::optional<Cloud> cloud = node::decodeCloud(msg, &why);
  if (!cloud) {
    // Nothing to track on: every part keeps its last pose and says why.
    ++stats_.invalid_frames;
    last_results_.clear();
    for (std::size_t i = 0; i < trackers_->size(); ++i) {
      const PartTracker& part = trackers_->part(i);
      TrackResult r;
      r.status = part.started() ? TrackStatus::kLost : TrackStatus::kWaiting;
      r.reason = "bad POINTS frame: " + why + (part.started() ? "; last good pose kept" : "; initial pose kept");
      r.T_cell_part = part.pose();
      out.push_back(toMessage(msg.utime, i, r));
    }
    stats_.last_problem = "POINTS: " + why;
  } else {
    // Cull the template with the cameras that saw this frame: with one silent, the points only
    // it could see are not in the scan and would pull ICP onto the powder.
    // Without culling by camera (cull_with_cameras false) a silent one is still said.
    std::vector<Point> seen_from;
    std::string seen_names;
    std::size_t seen = 0;
    for (const std::string& source : msg.sources)
      if (camera_names_.count(source) > 0) {
        ++seen;
        seen_names += (seen_names.empty() ? "" : ", ") + source;
        if (const auto cam = cameras_.find(source); cam != cameras_.end()) seen_from.push_back(cam->second);
      }
    const bool partial = seen > 0 && seen < camera_names_.size();
    const bool cull = partial && !seen_from.empty();
    // Frames dropped since the parts last tracked (this process tracks the newest POINTS only):
    // the filter's prediction covers the time (PartTracker::elapse). 1 after the clock went back.
    if (tracked_utime_ >= 0 && msg.utime > tracked_utime_ && frame_rate_ > 0) {
      const double periods = secondsBetween(msg.utime, tracked_utime_) * frame_rate_;
      for (std::size_t i = 0; i < trackers_->size(); ++i) trackers_->part(i).elapse(periods);
      stats_.max_gap_periods = std::max(stats_.max_gap_periods, periods);
    }
    tracked_utime_ = msg.utime;
    const std::vector<TrackResult> results = cull ? trackers_->track(*cloud, seen_from) : trackers_->track(*cloud);
    last_results_ = results;
    stats_.last_problem.clear();
    if (partial)
      stats_.last_problem = "POINTS from " + seen_names + " only" + (cull ? ": tracking on those cameras" : "");
    for (std::size_t i = 0; i < results.size(); ++i) {
      out.push_back(toMessage(msg.utime, i, results[i]));
      if (trackers_->part(i).started()) last_poses_[trackers_->part(i).name()] = {results[i].T_cell_part, msg.utime};
      // WAITING is phase 1 (the part still buried), not a problem.
      const bool fine = results[i].status == TrackStatus::kTracking || results[i].status == TrackStatus::kWaiting;
      if (!fine && stats_.last_problem.empty())
        stats_.last_problem = trackers_->part(i).name() + ": " + results[i].reason;
    }
    if (cloud->empty()) ++stats_.invalid_frames;
  }
  // Per-frame timing over the last 100 frames, for the heartbeat.
  recent_ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (recent_ms_.size() > 100) recent_ms_.pop_front();
  std::vector<double> sorted(recent_ms_.begin(), recent_ms_.end());
  std::sort(sorted.begin(), sorted.end());
  stats_.frame_ms_p50 = sorted[sorted.size() / 2];
  stats_.frame_ms_p90 = sorted[std::min(sorted.size() - 1, sorted.size() * 9 / 10)];
  stats_.frame_ms_max = sorted.back();
  return out;
}

}  // namespace depowder::tracker
