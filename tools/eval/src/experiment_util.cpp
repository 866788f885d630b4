#include "experiment_util.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <stdexcept>

#include "depowder/eval/experiment.hpp"

namespace depowder::eval {

std::uint64_t nameHash(const std::string& name) {
  std::uint64_t h = 1469598103934665603ull;
  for (const char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

Pose perturbed(const Pose& T, double max_trans, double max_rot, std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::Vector3d axis(normal(rng), normal(rng), normal(rng));
  Eigen::Vector3d dir(normal(rng), normal(rng), normal(rng));
  axis.normalize();
  dir.normalize();
  const double angle = max_rot * unit(rng), length = max_trans * unit(rng);
  Pose out = T;
  out.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * T.linear();
  out.translation() = T.translation() + length * dir;
  return out;
}

int frameSteps(const EvalCell& cell) { return std::max(1, static_cast<int>(std::lround(cell.step_hz / cell.fps))); }

double frameStep(const EvalCell& cell) { return 1.0 / (cell.fps * frameSteps(cell)); }

void advanceFrame(sim::World& world, const EvalCell& cell, const std::function<void(double t)>& before_step) {
  const int steps = frameSteps(cell);
  const double dt = frameStep(cell);
  for (int s = 0; s < steps; ++s) {
    if (before_step) before_step(world.time() + dt);
    world.step(dt);
  }
}

double mean(const std::vector<double>& v) {
  return v.empty() ? std::nan("") : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

std::string percent(double fraction) { return std::to_string(static_cast<int>(std::lround(fraction * 100))) + "%"; }

tracker::TrackerConfig baseTrackerConfig() {
  tracker::TrackerConfig c;
  c.eta1 = 0.0;
  return c;
}

tracker::TrackerConfig evalTrackerConfig(tracker::Method method, const EvalCell& cell) {
  tracker::TrackerConfig c = cell.tracker;
  c.method = method;
  c.viewpoints = viewpoints(cell.cameras);
  return c;
}

std::string traceHeader() {
  return "experiment,part,method,trial,frame,rot_err_deg,trans_err_mm,err_rx_deg,err_ry_deg,err_rz_deg,"
         "err_x_mm,err_y_mm,err_z_mm,moved_mm,turned_deg,status,iterations,inlier_ratio,rms_mm,eta,"
         "template_updated,refit,moving,falling,reset,eta_true";
}

std::string traceLine(const TraceRow& row) {
  const tracker::TrackResult& r = *row.result;
  const PoseError e = poseError(r.T_cell_part, row.T_true), moved = poseError(row.T_true, row.T_start);
  const Pose E = row.T_true.inverse(Eigen::Isometry) * r.T_cell_part;  // the error along the part's own axes
  const Eigen::AngleAxisd aa(E.linear());
  const Eigen::Vector3d w = aa.angle() * 180.0 / M_PI * aa.axis();
  const Eigen::Vector3d t = 1000.0 * E.translation();
  char buf[512];
  std::snprintf(buf, sizeof buf, "%s,%s,%s,%d,%d,%.3f,%.2f,%.3f,%.3f,%.3f,%.2f,%.2f,%.2f,%.2f,%.3f",
                row.experiment.c_str(), row.part.c_str(), row.method.c_str(), row.trial, row.frame, e.rot_deg,
                10.0 * e.trans_cm, w.x(), w.y(), w.z(), t.x(), t.y(), t.z(), 10.0 * moved.trans_cm, moved.rot_deg);
  std::string line = buf;
  std::snprintf(buf, sizeof buf, ",%s,%d,%.3f,%.2f,%.4f,%d,%d,%d,%d,%d,%.4f", tracker::toString(r.status), r.iterations,
                r.inlier_ratio, 1000.0 * r.fitness, r.eta, r.template_updated ? 1 : 0, r.refit ? 1 : 0,
                r.moving ? 1 : 0, r.falling ? 1 : 0, r.reset ? 1 : 0, row.eta_true);
  return line + buf;
}

}  // namespace depowder::eval
