#include "progress_node.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "depowder/clock.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/convert.hpp"

namespace depowder::progress {
ProgressNodeOptions readProgressOptions(const node::CellConfig& cell) {
  ProgressNodeOptions o;
  const node::YamlReader r = cell.root.child("progress");
  ProgressConfig& e = o.estimator;
  r.read("eta1", e.eta1, 0.0, 1.0);
  r.read("eta2", e.eta2, 0.0, 1.0);
  if (e.eta2 <= e.eta1) r.fail("eta2", "must be greater than eta1");
  r.read("band_offset", e.band_offset, -0.005, 0.05);
  r.read("band_width", e.band_width, 0.001, 0.05);
  r.read("top_margin", e.top_margin, -0.05, 0.1);
  r.read("min_band_points", e.min_band_points, 1, 100000);
  r.read("cover_margin", e.cover_margin, 0.0, 0.5);
  r.read("outlier_mad_k", e.outlier_mad_k, 0.0, 100.0);
  r.read("outlier_floor", e.outlier_floor, 0.0, 0.1);
  r.read("grid_cell", e.grid_cell, 0.0005, 0.01);
  r.read("contour_spacing", e.contour_spacing, 0.001, 0.1);
  r.read("contour_radius", e.contour_radius, 0.001, 0.1);
  r.read("contour_min_points", e.contour_min_points, 1, 1000);
  r.read("footprint_reuse", e.footprint_reuse, 0.0, 0.01);
  // What estimateProgress would refuse on every frame for a part (xi + band_offset <= 0): said now.
  for (const node::PartConfig& part : cell.parts)
    if (const std::string why = checkConfig(part.xi, e); !why.empty())
      r.fail("", "with part '" + part.name + "': " + why);
  r.read("cad_spacing", o.cad_spacing, 0.0005, 0.02);
  std::string mode = toString(o.filter.mode);
  r.readChoice("eta_filter", mode, {"median", "running_max", "running_max_reset", "none"});
  parseEtaFilterMode(mode, o.filter.mode);
  r.read("filter_window", o.filter.window, 1, 301);
  r.read("reset_rotation_deg", o.filter.reset_rotation_deg, 0.1, 180.0);
  r.read("reset_translation", o.filter.reset_translation, 0.001, 1.0);
  r.read("hysteresis", o.phase.hysteresis, 0.0, 0.5);
  r.read("done_eta", o.phase.done_eta, 0.0, 1.0);
  r.read("done_frames", o.phase.done_frames, 1, 10000);
  r.read("blast_min_s", o.phase.blast_min_s, 0.0, 3600.0);
  r.read("require_blast", o.phase.require_blast);
  r.read("pose_wait", o.pose_wait, 0.0, 5.0);
  r.read("pose_staleness", o.pose_staleness, 0.0, 60.0);
  r.read("use_initial_pose", o.use_initial_pose);
  r.read("max_pending", o.max_pending, 1, 100);
  r.read("heartbeat_period", o.heartbeat_period, 0.05, 10.0);
  r.finish();
  o.phase.eta1 = e.eta1;
  o.phase.eta2 = e.eta2;
  return o;
}

ProgressNode::ProgressNode(const node::CellConfig& cell, ProgressNodeOptions options) : options_(options) {
  for (const node::PartConfig& pc : cell.parts) {
    Part part{pc, {}, {}, EtaFilter(options_.filter), PhaseMachine(options_.phase)};
    part.cad = sampleSurface(node::loadPartMesh(pc), options_.cad_spacing).points;
    parts_.emplace(pc.name, std::move(part));
  }
}

std::vector<std::string> ProgressNode::partNames() const {
  std::vector<std::string> names;
  for (const auto& [name, part] : parts_) names.push_back(name);
  return names;
}

progress_t ProgressNode::process(Frame& frame, Part& part, const Pose* pose, const std::string& pose_note) {
  frame.done[part.config.name] = true;
  progress_t msg;
  msg.utime = frame.utime;
  msg.part = part.config.name;
  msg.eta = part.filter.value();
  msg.eta_raw = std::numeric_limits<double>::quiet_NaN();
  msg.h_pow = msg.h_max = msg.h_min = std::numeric_limits<double>::quiet_NaN();
  msg.T_cell_part = node::toMsg(pose ? *pose : Pose::Identity());
  msg.num_contour = msg.num_band = 0;
  ++stats_.estimates;

  if (!pose) {
    msg.status = progress_t::NO_POSE;
    msg.status_reason = pose_note;
    msg.phase = static_cast<std::int8_t>(part.phase.phase());
    ++stats_.no_pose;
    stats_.last_problem = part.config.name + ": " + pose_note;
    return msg;
  }

  // Alg. 1 line 11 with P_cad . T_i, then the filter and the phase (Sec. III-B).
  const auto start = std::chrono::steady_clock::now();
  const ProgressEstimate e =
      estimateProgress(transformed(part.cad, *pose), frame.cloud, part.config.xi, options_.estimator);
  stats_.last_compute_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (e.h_max > e.h_min) {  // computed (an estimate that stopped before them leaves 0 and 0: NaN here)
    msg.h_max = e.h_max;
    msg.h_min = e.h_min;
  }
  switch (e.status) {
    case Status::kOk:
      msg.status = progress_t::OK;
      msg.eta_raw = e.eta;
      msg.h_pow = e.h_pow;
      msg.eta = part.filter.update(e.eta, *pose);
      part.phase.update(msg.eta, frame.utime);
      break;
    case Status::kNoPose:
      msg.status = progress_t::NO_POSE;
      ++stats_.no_pose;
      break;
    case Status::kNoPoints:
      msg.status = progress_t::NO_POINTS;
      break;
    case Status::kNoContour:
    case Status::kBadConfig:  // readProgressOptions refuses such options (checkConfig); eta is held all the same
      msg.status = progress_t::NO_CONTOUR;
      break;
  }
  msg.status_reason = e.reason;
  if (!pose_note.empty()) msg.status_reason += (msg.status_reason.empty() ? "" : "; ") + pose_note;
  if (e.status != Status::kOk) stats_.last_problem = part.config.name + ": " + msg.status_reason;
  msg.phase = static_cast<std::int8_t>(part.phase.phase());
  auto pack = [](const Cloud& c, std::vector<std::vector<float>>& out) {
    out.reserve(c.size());
    for (const Point& p : c)
      out.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
  };
  pack(e.contour, msg.contour);
  pack(e.band, msg.band);
  msg.num_contour = static_cast<std::int32_t>(msg.contour.size());
  msg.num_band = static_cast<std::int32_t>(msg.band.size());
  return msg;
}

void ProgressNode::flush(Frame& frame, std::vector<progress_t>& out) {
  for (auto& [name, part] : parts_)
    if (!frame.done[name]) out.push_back(processWithNearestPose(frame, part));
}

progress_t ProgressNode::processWithNearestPose(Frame& frame, Part& part) {
  const std::int64_t staleness_us = static_cast<std::int64_t>(options_.pose_staleness * 1e6);
  const PoseRecord* best = nullptr;
  for (const PoseRecord& r : part.poses)  // the nearest in time within the staleness limit
    if (std::llabs(r.utime - frame.utime) <= staleness_us &&
        (!best || std::llabs(r.utime - frame.utime) < std::llabs(best->utime - frame.utime)))
      best = &r;
  if (best)
    return process(frame, part, &best->T_cell_part, best->utime == frame.utime ? "" : "pose from another frame");
  if (part.poses.empty() && options_.use_initial_pose && part.phase.phase() == Phase::kVacuumBuried)
    return process(frame, part, &part.config.T_cell_part_init, "no PART_POSE yet: initial pose (phase 1)");
  return process(frame, part, nullptr,
                 part.poses.empty() ? "no valid PART_POSE received for this part"
                                    : "no PART_POSE within pose_staleness of this frame");
}

std::vector<progress_t> ProgressNode::onPoints(std::int64_t utime, Cloud cloud, std::int64_t now_us) {
  ++stats_.frames;
  std::vector<progress_t> out;
  if (!utimeInRange(utime)) {
    stats_.last_problem = "POINTS with " + utimeOutOfRange(utime) + ": not used";
    ++stats_.input_problems;
    return out;
  }
  for (const Frame& f : pending_)
    if (f.utime == utime) {  // received twice: each (frame, part) is estimated once
      ++stats_.duplicate_frames;
      stats_.last_problem = "POINTS utime " + std::to_string(utime) + " received again: not used";
      ++stats_.input_problems;
      return out;
    }
  Frame frame{utime, now_us, std::move(cloud), {}};
  // A pose for this utime may already be here (the tracker was faster than our POINTS delivery);
  // the first one, as onPose does when the frame comes first (a PART_POSE may come twice).
  for (auto& [name, part] : parts_)
    for (const PoseRecord& r : part.poses)
      if (r.utime == utime && !frame.done[name]) out.push_back(process(frame, part, &r.T_cell_part, ""));
  pending_.push_back(std::move(frame));
  while (static_cast<int>(pending_.size()) > options_.max_pending) {
    flush(pending_.front(), out);
    pending_.pop_front();
  }
  return out;
}

std::vector<progress_t> ProgressNode::onPose(const part_pose_t& msg) {
  std::vector<progress_t> out;
  const auto it = parts_.find(msg.part);
  if (it == parts_.end()) {
    ++stats_.unknown_parts;
    stats_.last_problem = "PART_POSE for unknown part '" + msg.part + "'";
    ++stats_.input_problems;
    return out;
  }
  Part& part = it->second;
  std::string why;
  std::optional<Pose> pose = node::fromMsg(msg.T_cell_part, &why);
  if (pose && !utimeInRange(msg.utime)) {
    pose.reset();
    why = utimeOutOfRange(msg.utime);
  }
  if (!pose) {
    ++stats_.invalid_poses;
    stats_.last_problem = "invalid PART_POSE for '" + msg.part + "': " + why;
    ++stats_.input_problems;
    return out;
  }
  part.poses.push_back({msg.utime, *pose});
  while (part.poses.size() > 64) part.poses.pop_front();
  // The tracker publishes a part's poses in utime order, and a frame it skipped (a newer one had
  // arrived) gets none: every waiting frame up to this pose's goes out now, in order, with its
  // nearest pose (this one for the frame of its utime), so that the part's PROGRESS and its eta
  // filter stay in time order.
  for (Frame& frame : pending_)
    if (frame.utime <= msg.utime && !frame.done[msg.part]) out.push_back(processWithNearestPose(frame, part));
  // Frames whose every part is done can go.
  while (!pending_.empty()) {
    bool all = true;
    for (const auto& [name, p] : parts_) all = all && pending_.front().done[name];
    if (!all) break;
    pending_.pop_front();
  }
  return out;
}

void ProgressNode::onPlan(const nozzle_plan_t& msg) {
  const auto it = parts_.find(msg.part);
  if (it == parts_.end() || !utimeInRange(msg.utime)) return;
  bool air = msg.phase == progress_t::PHASE_AIR_BLAST;
  for (const waypoint_t& w : msg.waypoints) air = air || w.tool == waypoint_t::TOOL_AIR;
  if (air) it->second.phase.airBlastStarted(msg.utime);
}

std::vector<progress_t> ProgressNode::poll(std::int64_t now_us) {
  std::vector<progress_t> out;
  const std::int64_t wait_us = static_cast<std::int64_t>(options_.pose_wait * 1e6);
  while (!pending_.empty() && now_us - pending_.front().arrived_us >= wait_us) {
    flush(pending_.front(), out);
    pending_.pop_front();
  }
  return out;
}

}  // namespace depowder::progress
