// Fig. 10 on the simulator: the part carried by a linear actuator (constant velocity along
// cell x) or a turntable (constant yaw rate about its vertical axis) through the powder, at a
// set visibility. As in the paper's footnote, one sequence is recorded at a slow base speed and
// played back faster by sub-sampling its frames: factor k = k x the base speed at 30 fps.
// Every factor and method is tracked on the same frames, from the true initial pose.
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/eval/experiment.hpp"
#include "depowder/tracker/part_tracker.hpp"
#include "experiment_util.hpp"

namespace depowder::eval {

namespace {

enum class Motion { kLinear, kTurntable };

/// The part's pose at `s` along the motion (m along x, or rad of yaw about the vertical through
/// the bounding-box centre at the start).
Pose poseAt(Motion motion, const Pose& T0, const Eigen::Vector3d& centre, double s) {
  if (motion == Motion::kLinear) {
    Pose T = T0;
    T.translation().x() += s;
    return T;
  }
  const Eigen::Isometry3d spin =
      Eigen::Translation3d(centre) * Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(-centre);
  return spin * T0;
}

struct Outcome {
  std::vector<int> success;      ///< per method, per factor: 1 tracked to the end, 0 lost
  std::vector<PoseError> final;  ///< per method, per factor: the error at the last frame
  double eta_start = 0;          ///< simulator truth after digging, before the motion
  double eta_end = 0;
  bool interrupted = false;
};

Outcome runMotion(Motion motion, const EvalCell& cell, const EvalPart& part,
                  const std::vector<tracker::Method>& methods, const SpeedOptions& o, double visibility, const Pose& T0,
                  std::uint32_t seed, const std::vector<int>& factors, double base, double travel,
                  const RunControl& control, double& done, double total, const std::string& label) {
  const Eigen::Vector3d centre = bounds(transformed(part.mesh, T0)).center();
  sim::World world(cell.sim, cell.box, {{part.name, part.mesh, T0, 1000}}, cell.cameras, seed);
  // The crater along the whole path, dug from the far end back to the start, so the part keeps
  // its visibility as it moves (powder left where it was is dug again at the next pose).
  const double step = motion == Motion::kLinear ? o.dig_step : o.dig_step / 0.1;
  const int digs = std::max(1, static_cast<int>(std::ceil(travel / step)));
  for (int i = digs; i >= 0; --i) {
    world.setPartPose(0, poseAt(motion, T0, centre, travel * i / digs));
    world.digToVisibility(0, visibility);
  }
  world.removeNozzle();
  Outcome out;
  out.eta_start = world.partTruth(0).eta;

  const int frames = static_cast<int>(std::lround(travel / base * cell.fps));
  std::vector<std::vector<tracker::PartTracker>> trackers(methods.size());
  for (std::size_t m = 0; m < methods.size(); ++m)
    for (std::size_t k = 0; k < factors.size(); ++k)
      trackers[m].emplace_back(part.name, part.mesh, T0, part.xi, evalTrackerConfig(methods[m], cell));
  std::vector<Pose> last(methods.size() * factors.size(), T0);
  std::vector<Pose> truth_at_last(last.size(), T0);
  FrameSource source(cell);
  for (int f = 1; f <= frames; ++f) {
    if (control.stopped()) {
      out.interrupted = true;
      return out;
    }
    advanceFrame(world, cell, [&](double t) { world.setPartPose(0, poseAt(motion, T0, centre, base * t)); });
    // The crater follows the part: without it the powder the moving part leaves behind (the simulator
    // raises the surface to the part's top where it was) slides into the band and buries it, and the
    // visibility under test would fall during the run.
    if (o.follow_crater) world.digToVisibility(0, visibility);
    const Cloud scan = source.capture(world);
    const sim::PartTruth truth = world.partTruth(0);
    for (std::size_t k = 0; k < factors.size(); ++k) {
      if (f % factors[k] != 0) continue;  // sub-sampling: factor k sees every k-th frame
      for (std::size_t m = 0; m < methods.size(); ++m) {
        last[m * factors.size() + k] = trackers[m][k].track(scan).T_cell_part;
        truth_at_last[m * factors.size() + k] = truth.T_cell_part;
      }
    }
    out.eta_end = truth.eta;
    done += 1;
    control.tell(done, total, label);
  }
  for (std::size_t i = 0; i < last.size(); ++i) {
    const PoseError e = poseError(last[i], truth_at_last[i]);
    out.success.push_back(e.rot_deg <= o.success_rot_deg && e.trans_cm <= o.success_trans * 100);
    out.final.push_back(e);
  }
  return out;
}

void accumulate(SpeedCurve& curve, const Outcome& out, std::size_t m, std::size_t factors) {
  curve.success_rate.resize(factors, 0.0);
  curve.final_rot_err_deg.resize(factors, 0.0);
  curve.final_trans_err_cm.resize(factors, 0.0);
  for (std::size_t k = 0; k < factors; ++k) {
    curve.success_rate[k] += out.success[m * factors + k];
    curve.final_rot_err_deg[k] += out.final[m * factors + k].rot_deg;
    curve.final_trans_err_cm[k] += out.final[m * factors + k].trans_cm;
  }
}

void finishCurve(SpeedCurve& curve, int trials) {
  for (auto* v : {&curve.success_rate, &curve.final_rot_err_deg, &curve.final_trans_err_cm})
    for (double& x : *v) x /= trials;
}

Json curveJson(const SpeedCurve& c, const std::vector<double>& speeds) {
  Json j = Json::object();
  j.set("speeds", Json::arrayOf(speeds));
  j.set("success_rate", Json::arrayOf(c.success_rate));
  j.set("final_rot_err_deg", Json::arrayOf(c.final_rot_err_deg));
  j.set("final_trans_err_cm", Json::arrayOf(c.final_trans_err_cm));
  return j;
}

/// The last speed of the increasing list still tracked (0 if the first was not).
double maxTracked(const std::vector<int>& success, std::size_t m, const std::vector<int>& factors, double base) {
  double best = 0;
  for (std::size_t k = 0; k < factors.size(); ++k) {
    if (!success[m * factors.size() + k]) break;
    best = factors[k] * base;
  }
  return best;
}

}  // namespace

SpeedResult runSpeed(const EvalCell& cell, const std::vector<EvalPart>& parts,
                     const std::vector<tracker::Method>& methods, const SpeedOptions& o, const RunControl& control) {
  SpeedResult result;
  result.eta1 = cell.tracker.eta1;
  const double base_rot = o.turntable_base_deg * M_PI / 180.0, travel_rot = o.turntable_travel_deg * M_PI / 180.0;
  // A factor past the travel's frames would never track a frame: its "final error" would be the
  // start pose's, 0, a success at a speed never tried. Increasing: a trial's figure is the last
  // speed of the list still tracked.
  const auto checkFactors = [](const std::vector<int>& factors, double frames, const std::string& which) {
    for (std::size_t k = 0; k < factors.size(); ++k)
      if (factors[k] < 1 || factors[k] > frames || (k > 0 && factors[k] <= factors[k - 1]))
        throw std::invalid_argument("speed: " + which + " factors must increase from 1 up to the travel's " +
                                    std::to_string(static_cast<long>(frames)) + " frames (factor " +
                                    std::to_string(factors[k]) + ")");
    if (factors.empty()) throw std::invalid_argument("speed: no " + which + " factors");
  };
  const double linear_frames = std::lround(o.linear_travel / o.linear_base * cell.fps);
  const double turntable_frames = std::lround(travel_rot / base_rot * cell.fps);
  checkFactors(o.linear_factors, linear_frames, "linear");
  checkFactors(o.turntable_factors, turntable_frames, "turntable");
  const double frames_per_trial = linear_frames + turntable_frames;
  const double total = static_cast<double>(parts.size() * o.visibilities.size()) * o.trials * frames_per_trial;
  double done = 0;
  for (const EvalPart& part : parts) {
    for (const double visibility : o.visibilities) {
      std::vector<SpeedRow> rows(methods.size());
      for (std::size_t m = 0; m < methods.size(); ++m) {
        rows[m].part = part.name;
        rows[m].method = tracker::toString(methods[m]);
        rows[m].visibility = visibility;
        rows[m].max_trans_tried_cm_s = o.linear_factors.back() * o.linear_base * 100;
        rows[m].max_rot_tried_deg_s = o.turntable_factors.back() * o.turntable_base_deg;
      }
      int trials_done = 0;
      double eta_start = 0, eta_lin = 0, eta_rot = 0;
      for (int trial = 0; trial < o.trials; ++trial) {
        const std::uint32_t seed =
            trialSeed(o.seed, nameHash(part.name) ^ 0x5eed, std::lround(visibility * 1000), trial);
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        const double yaw = 2 * M_PI * unit(rng);
        const std::string label = "speed " + part.name + " " + percent(visibility) + " trial " +
                                  std::to_string(trial + 1) + "/" + std::to_string(o.trials);
        // Linear: from x = -travel/2 to +travel/2 through the box centre.
        const Pose T_lin = placePart(part.mesh, yaw, {-0.5 * o.linear_travel, 0.0}, o.bottom_z);
        const Outcome lin =
            runMotion(Motion::kLinear, cell, part, methods, o, visibility, T_lin, seed, o.linear_factors, o.linear_base,
                      o.linear_travel, control, done, total, label + " linear");
        if (lin.interrupted) {
          result.interrupted = true;
          break;
        }
        const Pose T_rot = placePart(part.mesh, yaw, {0.0, 0.0}, o.bottom_z);
        const Outcome rot =
            runMotion(Motion::kTurntable, cell, part, methods, o, visibility, T_rot, seed + 1, o.turntable_factors,
                      base_rot, travel_rot, control, done, total, label + " turntable");
        if (rot.interrupted) {
          result.interrupted = true;
          break;
        }
        ++trials_done;
        eta_start += lin.eta_start;
        eta_lin += lin.eta_end;
        eta_rot += rot.eta_end;
        for (std::size_t m = 0; m < methods.size(); ++m) {
          rows[m].trial_trans_speed_cm_s.push_back(maxTracked(lin.success, m, o.linear_factors, o.linear_base) * 100);
          rows[m].trial_rot_speed_deg_s.push_back(
              maxTracked(rot.success, m, o.turntable_factors, o.turntable_base_deg));
          accumulate(rows[m].trans_curve, lin, m, o.linear_factors.size());
          accumulate(rows[m].rot_curve, rot, m, o.turntable_factors.size());
        }
      }
      if (trials_done == 0) return result;
      for (SpeedRow& row : rows) {
        row.trials = trials_done;
        row.true_eta_start = eta_start / trials_done;
        row.true_eta_end_linear = eta_lin / trials_done;
        row.true_eta_end_turntable = eta_rot / trials_done;
        row.max_trans_speed_cm_s = mean(row.trial_trans_speed_cm_s);
        row.max_rot_speed_deg_s = mean(row.trial_rot_speed_deg_s);
        finishCurve(row.trans_curve, trials_done);
        finishCurve(row.rot_curve, trials_done);
        result.rows.push_back(row);
      }
      if (result.interrupted) return result;
    }
  }
  return result;
}

Json toJson(const SpeedResult& result, const SpeedOptions& o) {
  Json doc = Json::object();
  doc.set("experiment", "speed");
  doc.set("seed", o.seed);
  doc.set("interrupted", result.interrupted);
  Json opt = Json::object();
  opt.set("visibilities", Json::arrayOf(o.visibilities));
  opt.set("trials", o.trials);
  std::vector<double> lin, rot;
  for (int k : o.linear_factors) lin.push_back(k * o.linear_base * 100);
  for (int k : o.turntable_factors) rot.push_back(k * o.turntable_base_deg);
  opt.set("trans_speeds_cm_s", Json::arrayOf(lin));
  opt.set("rot_speeds_deg_s", Json::arrayOf(rot));
  opt.set("linear_travel_m", o.linear_travel);
  opt.set("turntable_travel_deg", o.turntable_travel_deg);
  opt.set("success_rot_deg", o.success_rot_deg);
  opt.set("success_trans_m", o.success_trans);
  opt.set("eta1", result.eta1);
  opt.set("follow_crater", o.follow_crater);
  doc.set("options", opt);
  Json rows = Json::array();
  for (const SpeedRow& r : result.rows) {
    Json j = Json::object();
    j.set("part", r.part);
    j.set("method", r.method);
    j.set("visibility", r.visibility);
    j.set("max_trans_speed_cm_s", r.max_trans_speed_cm_s);
    j.set("max_rot_speed_deg_s", r.max_rot_speed_deg_s);
    j.set("trials", r.trials);
    j.set("trial_trans_speed_cm_s", Json::arrayOf(r.trial_trans_speed_cm_s));
    j.set("trial_rot_speed_deg_s", Json::arrayOf(r.trial_rot_speed_deg_s));
    j.set("linear", curveJson(r.trans_curve, lin));
    j.set("turntable", curveJson(r.rot_curve, rot));
    j.set("true_eta_start", r.true_eta_start);
    j.set("true_eta_end_linear", r.true_eta_end_linear);
    j.set("true_eta_end_turntable", r.true_eta_end_turntable);
    rows.push(std::move(j));
  }
  doc.set("rows", std::move(rows));
  return doc;
}

}  // namespace depowder::eval
