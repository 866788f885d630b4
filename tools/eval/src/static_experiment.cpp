// Table I on the simulator: a part held still at a set visibility while the nozzle circles it
// (the paper's Fig. 7), the tracker started from a slightly wrong initial pose.
#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include "depowder/eval/experiment.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/tracker/part_tracker.hpp"
#include "experiment_util.hpp"

namespace depowder::eval {

namespace {

struct TrialFigures {
  double rot_sum = 0, trans_sum = 0, tilt_sum = 0;
  PoseError last;
  int frames = 0, tracked = 0, lost = 0, updates = 0;
  double template_size_sum = 0, ms_sum = 0;
};

sim::NozzleScript orbitAround(const Eigen::AlignedBox3d& b, const StaticOptions& o, double start_deg) {
  sim::ScriptSegment seg;
  seg.kind = sim::ScriptSegment::Kind::kOrbit;
  seg.orbit.centre = b.center().head<2>();
  seg.orbit.radii = 0.5 * b.sizes().head<2>() + Eigen::Vector2d::Constant(o.nozzle_standoff);
  seg.orbit.height = b.max().z() + o.nozzle_above;
  seg.orbit.period = o.nozzle_period;
  seg.orbit.start_deg = start_deg;
  seg.orbit.tilt_deg = o.nozzle_tilt_deg;
  seg.orbit.revolutions = 1e6;
  seg.orbit.tool = Tool::kOff;  // the nozzle only occludes and interferes: visibility stays as set
  return sim::NozzleScript({seg}, true);
}

}  // namespace

StaticResult runStatic(const EvalCell& cell, const std::vector<EvalPart>& parts,
                       const std::vector<tracker::Method>& methods, const StaticOptions& o, const RunControl& control) {
  StaticResult result;
  result.eta1 = cell.tracker.eta1;
  const int frames = std::max(1, static_cast<int>(std::lround(o.duration * cell.fps)));
  const double total = static_cast<double>(parts.size() * o.visibilities.size()) * o.trials * frames;
  double done = 0;

  for (const EvalPart& part : parts) {
    for (const double visibility : o.visibilities) {
      std::vector<StaticRow> rows(methods.size());
      for (std::size_t m = 0; m < methods.size(); ++m) {
        rows[m].part = part.name;
        rows[m].method = tracker::toString(methods[m]);
        rows[m].visibility = visibility;
        rows[m].frames = frames;
      }
      double eta_sum = 0;
      int trials_done = 0;
      for (int trial = 0; trial < o.trials && !result.interrupted; ++trial) {
        const std::uint32_t seed = trialSeed(o.seed, nameHash(part.name), std::lround(visibility * 1000), trial);
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        // The trial's scene: a seeded yaw and offset, the crater dug to the visibility.
        const double yaw = 2 * M_PI * unit(rng);
        const double r = o.max_offset * std::sqrt(unit(rng)), a = 2 * M_PI * unit(rng);
        const Pose T_true = placePart(part.mesh, yaw, {r * std::cos(a), r * std::sin(a)}, o.bottom_z);
        sim::World world(cell.sim, cell.box, {{part.name, part.mesh, T_true, 1000}}, cell.cameras, seed);
        world.digToVisibility(0, visibility);
        const sim::NozzleScript script = orbitAround(bounds(transformed(part.mesh, T_true)), o, 360.0 * unit(rng));
        // The printer's pose with a small seeded error, the same for every method.
        const Pose T_init = perturbed(T_true, o.init_trans, o.init_rot_deg * M_PI / 180.0, rng);
        const PoseError init_err = poseError(T_init, T_true);

        std::vector<tracker::PartTracker> trackers;
        for (tracker::Method method : methods)
          trackers.emplace_back(part.name, part.mesh, T_init, part.xi, evalTrackerConfig(method, cell));
        std::vector<TrialFigures> fig(methods.size());
        FrameSource source(cell);
        double eta = 0;
        bool cut = false;
        for (int f = 0; f < frames; ++f) {
          if (control.stopped()) {
            cut = true;
            break;
          }
          Pose T_nozzle = Pose::Identity();
          advanceFrame(world, cell, [&](double t) {
            if (!o.nozzle) return world.removeNozzle();
            const sim::ArmState arm = script.at(t);
            world.setArm(arm);
            T_nozzle = arm.T_cell_nozzle;
          });
          const Cloud scan = source.capture(world, o.nozzle && o.self_filter ? &T_nozzle : nullptr);
          const sim::PartTruth truth = world.partTruth(0);
          eta += truth.eta;
          for (std::size_t m = 0; m < methods.size(); ++m) {
            const tracker::TrackResult tr = trackers[m].track(scan);
            control.record({"static", part.name, tracker::toString(methods[m]), trial, f, truth.T_cell_part, T_true,
                            truth.eta, &tr});
            const PoseError e = poseError(tr.T_cell_part, truth.T_cell_part);
            TrialFigures& g = fig[m];
            g.rot_sum += e.rot_deg;
            g.trans_sum += e.trans_cm;
            g.tilt_sum += tiltError(tr.T_cell_part, truth.T_cell_part);
            g.last = e;
            ++g.frames;
            g.tracked += tr.status == tracker::TrackStatus::kTracking;
            g.lost += tr.status == tracker::TrackStatus::kLost || tr.status == tracker::TrackStatus::kWaiting;
            g.updates += tr.template_updated;
            g.template_size_sum += static_cast<double>(tr.template_size);
            g.ms_sum += tr.timing.total_ms;
          }
          done += 1;
          control.tell(done, total,
                       "static " + part.name + " " + percent(visibility) + " trial " + std::to_string(trial + 1) + "/" +
                           std::to_string(o.trials));
        }
        if (cut) {
          result.interrupted = true;
          break;
        }
        ++trials_done;
        eta_sum += eta / frames;
        for (std::size_t m = 0; m < methods.size(); ++m) {
          const TrialFigures& g = fig[m];
          StaticRow& row = rows[m];
          const double rot = g.rot_sum / g.frames, trans = g.trans_sum / g.frames;
          row.trial_rot_err_deg.push_back(rot);
          row.trial_trans_err_cm.push_back(trans);
          row.worst_trial_rot_err_deg = std::max(row.worst_trial_rot_err_deg, rot);
          row.worst_trial_trans_err_cm = std::max(row.worst_trial_trans_err_cm, trans);
          row.tilt_err_deg += g.tilt_sum / g.frames;
          row.final_rot_err_deg += g.last.rot_deg;
          row.final_trans_err_cm += g.last.trans_cm;
          row.init_rot_err_deg += init_err.rot_deg;
          row.init_trans_err_cm += init_err.trans_cm;
          row.tracked_fraction += static_cast<double>(g.tracked) / g.frames;
          row.lost_fraction += static_cast<double>(g.lost) / g.frames;
          row.template_updates += g.updates;
          row.template_size += g.template_size_sum / g.frames;
          row.track_ms += g.ms_sum / g.frames;
        }
      }
      if (trials_done == 0) return result;
      for (StaticRow& row : rows) {
        const double n = trials_done;
        row.trials = trials_done;
        row.true_eta = eta_sum / n;
        row.rot_err_deg = mean(row.trial_rot_err_deg);  // equal frame counts: the mean over all frames
        row.trans_err_cm = mean(row.trial_trans_err_cm);
        for (double* v : {&row.tilt_err_deg, &row.final_rot_err_deg, &row.final_trans_err_cm, &row.init_rot_err_deg,
                          &row.init_trans_err_cm, &row.tracked_fraction, &row.lost_fraction, &row.template_updates,
                          &row.template_size, &row.track_ms})
          *v /= n;
        result.rows.push_back(row);
      }
      if (result.interrupted) return result;
    }
  }
  return result;
}

Json toJson(const StaticResult& result, const StaticOptions& o) {
  Json doc = Json::object();
  doc.set("experiment", "static");
  doc.set("seed", o.seed);
  doc.set("interrupted", result.interrupted);
  Json opt = Json::object();
  opt.set("visibilities", Json::arrayOf(o.visibilities));
  opt.set("trials", o.trials);
  opt.set("duration_s", o.duration);
  opt.set("init_trans_max_m", o.init_trans);
  opt.set("init_rot_max_deg", o.init_rot_deg);
  opt.set("max_offset_m", o.max_offset);
  opt.set("nozzle", o.nozzle);
  opt.set("self_filter", o.self_filter);
  opt.set("nozzle_standoff_m", o.nozzle_standoff);
  opt.set("nozzle_above_top_m", o.nozzle_above);
  opt.set("nozzle_period_s", o.nozzle_period);
  opt.set("nozzle_tilt_deg", o.nozzle_tilt_deg);
  opt.set("eta1", result.eta1);
  doc.set("options", opt);
  Json rows = Json::array();
  for (const StaticRow& r : result.rows) {
    Json j = Json::object();
    j.set("part", r.part);
    j.set("method", r.method);
    j.set("visibility", r.visibility);
    j.set("rot_err_deg", r.rot_err_deg);
    j.set("trans_err_cm", r.trans_err_cm);
    j.set("tilt_err_deg", r.tilt_err_deg);
    j.set("final_rot_err_deg", r.final_rot_err_deg);
    j.set("final_trans_err_cm", r.final_trans_err_cm);
    j.set("worst_trial_rot_err_deg", r.worst_trial_rot_err_deg);
    j.set("worst_trial_trans_err_cm", r.worst_trial_trans_err_cm);
    j.set("init_rot_err_deg", r.init_rot_err_deg);
    j.set("init_trans_err_cm", r.init_trans_err_cm);
    j.set("true_eta", r.true_eta);
    j.set("trials", r.trials);
    j.set("frames_per_trial", r.frames);
    j.set("tracked_fraction", r.tracked_fraction);
    j.set("lost_fraction", r.lost_fraction);
    j.set("template_updates", r.template_updates);
    j.set("template_size", r.template_size);
    j.set("track_ms", r.track_ms);
    j.set("trial_rot_err_deg", Json::arrayOf(r.trial_rot_err_deg));
    j.set("trial_trans_err_cm", Json::arrayOf(r.trial_trans_err_cm));
    rows.push(std::move(j));
  }
  doc.set("rows", std::move(rows));
  return doc;
}

}  // namespace depowder::eval
