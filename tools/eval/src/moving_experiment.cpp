// Table II on the simulator: the nozzle pushes a part through the powder from a seeded contact
// point until it reaches the box edge (sim/push.hpp, rigid-body physics), from an initial
// visibility of 40 to 60 %; a trial succeeds if the final error is within 15 deg and 15 mm.
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <unordered_map>

#include "depowder/eval/experiment.hpp"
#include "depowder/sim/physics.hpp"
#include "depowder/sim/push.hpp"
#include "depowder/stats.hpp"
#include "depowder/tracker/part_tracker.hpp"
#include "experiment_util.hpp"

namespace depowder::eval {

MovingResult runMoving(const EvalCell& cell_in, const std::vector<EvalPart>& parts,
                       const std::vector<tracker::Method>& methods, const MovingOptions& o, const RunControl& control) {
  MovingResult result;
  result.eta1 = cell_in.tracker.eta1;
  EvalCell cell = cell_in;
  cell.sim.physics.enabled = true;
  const int max_frames = static_cast<int>(std::lround(o.max_duration * cell.fps));
  const MotionPart oracle_part = o.motion_oracle.empty() ? MotionPart::kFull : motionPart(o.motion_oracle);
  const double total = static_cast<double>(parts.size()) * o.trials * max_frames;
  double done = 0;
  for (const EvalPart& part : parts) {
    std::vector<MovingRow> rows(methods.size());
    for (std::size_t m = 0; m < methods.size(); ++m) {
      rows[m].part = part.name;
      rows[m].method = tracker::toString(methods[m]);
    }
    int trials_done = 0;
    for (int trial = 0; trial < o.trials; ++trial) {
      const std::uint32_t seed = trialSeed(o.seed, nameHash(part.name) ^ 0x9a5, 0, trial);
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> unit(0.0, 1.0);
      // The trial: a seeded yaw and initial visibility, a contact point on the visible part
      // (azimuth, a height above the powder, a sideways offset that makes the push turn it).
      const double yaw = 2 * M_PI * unit(rng);
      const double visibility = o.min_visibility + (o.max_visibility - o.min_visibility) * unit(rng);
      const Pose T0 = placePart(part.mesh, yaw, {0.0, 0.0}, o.bottom_z);
      sim::World world(cell.sim, cell.box, {{part.name, part.mesh, T0, 1000}}, cell.cameras, seed);
      world.digToVisibility(0, visibility);
      const Eigen::AlignedBox3d box0 = bounds(transformed(part.mesh, T0));
      const double size = box0.sizes().head<2>().norm();
      // The contact height: about the centre of mass's, so the push slides the part (pushed high, a
      // part buried to its middle tips over the powder that holds its base). It may be a little below
      // the powder line: the nozzle reaches into the loose powder beside the part.
      const double com = ((T0 * world.physics()->massProperties(0).centre).z() - box0.min().z()) / box0.sizes().z();
      const double lo = std::clamp(com - 0.5 * o.contact_band, 0.05, 0.95);
      const double hi = std::clamp(com + 0.5 * o.contact_band, 0.05, 0.95);
      // A contact point the nozzle can reach: redrawn until the push line meets the part (thin parts).
      sim::PushSpec spec;
      bool hit = false;
      for (int attempt = 0; attempt < 100 && !hit; ++attempt) {
        const double azimuth = 360.0 * unit(rng);
        const double height = lo + (hi - lo) * unit(rng);
        const double offset = o.max_offset_fraction * size * (2 * unit(rng) - 1);
        try {
          spec = sim::pushFrom(world, 0, azimuth, height, offset);
          hit = true;
        } catch (const std::invalid_argument&) {
        }
      }
      if (!hit) throw std::runtime_error("moving: no push line meets part '" + part.name + "'");
      spec.speed = o.push_speed;
      // The powder at the visibility's level along the whole path to the wall (dug from the wall back
      // to the start), as a part pushed at 40 to 60 % stays partly visible; the part still ploughs the
      // powder it meets (piled in front, spread behind) and drives the powder's changes.
      if (o.dig_path) {
        Eigen::Vector3d dir = spec.direction;
        dir.z() = 0;
        dir.normalize();
        const Eigen::AlignedBox3d inside(Eigen::Vector3d(-0.5 * cell.box.size.x(), -0.5 * cell.box.size.y(), 0.0),
                                         Eigen::Vector3d(0.5 * cell.box.size.x(), 0.5 * cell.box.size.y(), 1.0));
        std::vector<Pose> path;
        for (double s = 0; s < 0.5; s += o.dig_step) {
          Pose T = T0;
          T.translation() += s * dir;
          if (!inside.contains(bounds(transformed(part.mesh, T)))) break;
          path.push_back(T);
        }
        for (auto it = path.rbegin(); it != path.rend(); ++it) {
          world.setPartPose(0, *it);
          world.digToVisibility(0, visibility);
        }
        world.setPartPose(0, T0);
      }
      sim::PushScript push(world, spec);
      const double eta0 = world.partTruth(0).eta;
      // --motion-oracle physics: a second world, the same part, where each frame replays from the estimate.
      std::unique_ptr<sim::World> shadow;
      if (oracle_part == MotionPart::kPhysics)
        shadow = std::make_unique<sim::World>(
            cell.sim, cell.box, std::vector<sim::PartSpec>{{part.name, part.mesh, T0, 1000}}, cell.cameras, seed);
      // physics-scan: each tracker's powder as the scans show it, from the bed at the start.
      const bool scan_powder = o.motion_oracle == "physics-scan";
      std::vector<sim::PowderField> seen(scan_powder ? methods.size() : 0, world.powder());
      for (sim::PowderField& s : seen) {  // no part in it: the shadow puts one at each estimate
        const double floor = *std::min_element(s.floors().begin(), s.floors().end());
        s.setFloor(std::vector<double>(s.size(), floor), std::vector<std::uint8_t>(s.size(), 0));
      }
      const Eigen::AlignedBox3d box_part = bounds(part.mesh);

      std::vector<tracker::PartTracker> trackers;
      for (tracker::Method method : methods)
        trackers.emplace_back(part.name, part.mesh, T0, part.xi, evalTrackerConfig(method, cell));
      std::vector<Pose> last(methods.size(), T0);
      std::vector<tracker::TrackStatus> last_status(methods.size(), tracker::TrackStatus::kWaiting);
      FrameSource source(cell);
      bool cut = false;
      double min_eta = eta0;
      int f = 0;
      Pose T_true_last = T0;
      for (; f < max_frames && push.phase() != sim::PushPhase::kDone; ++f) {
        if (control.stopped()) {
          cut = true;
          break;
        }
        sim::ArmState arm;
        std::vector<sim::ArmState> arm_steps;  // the frame's, for the shadow's replay
        advanceFrame(world, cell, [&](double t) {
          arm = push.update(t);
          if (shadow) arm_steps.push_back(arm);
          world.setArm(arm);
        });
        const bool filtered = o.self_filter && arm.nozzle_present;
        const Cloud scan = source.capture(world, filtered ? &arm.T_cell_nozzle : nullptr);
        const sim::PartTruth truth = world.partTruth(0);
        min_eta = std::min(min_eta, truth.eta);
        if (shadow) {
          for (std::size_t m = 0; m < methods.size(); ++m) {
            if (scan_powder)
              powderFromScan(seen[m], scan, arm.nozzle_present ? &arm.T_cell_nozzle : nullptr, box_part, last[m], 0.01);
            const Pose T_next =
                physicsMotion(*shadow, scan_powder ? seen[m] : world.powder(), last[m], arm_steps, frameStep(cell)) *
                last[m];
            trackers[m].predictMotion(oracleMotion(last[m], T_next, MotionPart::kFull, o.motion_oracle_fraction));
          }
        } else if (!o.motion_oracle.empty()) {
          const Pose delta = oracleMotion(T_true_last, truth.T_cell_part, oracle_part, o.motion_oracle_fraction);
          for (tracker::PartTracker& t : trackers) t.predictMotion(delta);
        }
        T_true_last = truth.T_cell_part;
        for (std::size_t m = 0; m < methods.size(); ++m) {
          const tracker::TrackResult tr = trackers[m].track(scan);
          last[m] = tr.T_cell_part;
          last_status[m] = tr.status;
          control.record(
              {"moving", part.name, tracker::toString(methods[m]), trial, f, truth.T_cell_part, T0, truth.eta, &tr});
        }
        if (o.probe_every > 0 && f % o.probe_every == 0) {
          const Pose& T_true = truth.T_cell_part;  // this frame's, as the trackers saw it
          for (std::size_t m = 0; m < methods.size(); ++m) {
            tracker::TrackerConfig c = evalTrackerConfig(methods[m], cell);
            c.filter.data_inflation = 0;  // the scan alone
            tracker::PartTracker probe(part.name, part.mesh, T_true, part.xi, c);
            tracker::TrackResult fit;
            for (int k = 0; k < o.probe_fits; ++k) fit = probe.track(scan);
            if (fit.status != tracker::TrackStatus::kTracking && fit.status != tracker::TrackStatus::kDegraded)
              continue;  // no fit: the pose kept at the truth says nothing
            const PoseError e = poseError(fit.T_cell_part, T_true);
            rows[m].probe_rot_err_deg.push_back(e.rot_deg);
            rows[m].probe_trans_err_cm.push_back(e.trans_cm);
          }
        }
        done += 1;
        control.tell(done, total,
                     "moving " + part.name + " trial " + std::to_string(trial + 1) + "/" + std::to_string(o.trials));
      }
      if (cut) {
        result.interrupted = true;
        break;
      }
      done += max_frames - f;  // a push that ended early
      ++trials_done;
      const sim::PartTruth truth = world.partTruth(0);
      const PoseError moved = poseError(truth.T_cell_part, T0);
      const double tilt = tiltError(truth.T_cell_part, T0);  // the part's vertical axis turned: tipped over
      for (std::size_t m = 0; m < methods.size(); ++m) {
        const PoseError e = poseError(last[m], truth.T_cell_part);
        MovingRow& row = rows[m];
        const bool ok = e.rot_deg <= o.success_rot_deg && e.trans_cm <= o.success_trans * 100;
        row.trial_success.push_back(ok);
        row.trial_final_rot_err_deg.push_back(e.rot_deg);
        row.trial_final_trans_err_cm.push_back(e.trans_cm);
        row.trial_visibility.push_back(eta0);
        row.trial_moved_cm.push_back(moved.trans_cm);
        row.trial_turned_deg.push_back(moved.rot_deg);
        row.trial_tilt_deg.push_back(tilt);
        row.trial_outcome.push_back(sim::toString(push.outcome()));
        row.trial_min_visibility.push_back(min_eta);
        row.trial_final_status.push_back(tracker::toString(last_status[m]));
      }
    }
    if (trials_done == 0) return result;
    for (MovingRow& row : rows) {
      row.trials = trials_done;
      std::vector<double> s(row.trial_success.begin(), row.trial_success.end());
      row.success = mean(s);
      row.final_rot_err_deg = mean(row.trial_final_rot_err_deg);
      row.final_trans_err_cm = mean(row.trial_final_trans_err_cm);
      row.visibility = mean(row.trial_visibility);
      row.moved_cm = mean(row.trial_moved_cm);
      row.turned_deg = mean(row.trial_turned_deg);
      row.probe_rot_mean_deg = mean(row.probe_rot_err_deg);
      row.probe_rot_p90_deg = percentile(row.probe_rot_err_deg, 0.9);
      row.probe_trans_mean_cm = mean(row.probe_trans_err_cm);
      result.rows.push_back(row);
    }
    if (result.interrupted) return result;
  }
  return result;
}

Json toJson(const MovingResult& result, const MovingOptions& o) {
  Json doc = Json::object();
  doc.set("experiment", "moving");
  doc.set("seed", o.seed);
  doc.set("interrupted", result.interrupted);
  Json opt = Json::object();
  opt.set("trials", o.trials);
  opt.set("min_visibility", o.min_visibility);
  opt.set("max_visibility", o.max_visibility);
  opt.set("push_speed_m_s", o.push_speed);
  opt.set("max_duration_s", o.max_duration);
  opt.set("dig_path", o.dig_path);
  opt.set("self_filter", o.self_filter);
  opt.set("probe_every", o.probe_every);
  if (!o.motion_oracle.empty()) {
    opt.set("motion_oracle", o.motion_oracle);
    opt.set("motion_oracle_fraction", o.motion_oracle_fraction);
  }
  opt.set("probe_fits", o.probe_fits);
  opt.set("contact_band", o.contact_band);
  opt.set("max_offset_fraction", o.max_offset_fraction);
  opt.set("success_rot_deg", o.success_rot_deg);
  opt.set("success_trans_m", o.success_trans);
  opt.set("eta1", result.eta1);
  doc.set("options", opt);
  Json rows = Json::array();
  for (const MovingRow& r : result.rows) {
    Json j = Json::object();
    j.set("part", r.part);
    j.set("method", r.method);
    j.set("visibility", r.visibility);
    j.set("success", r.success);
    j.set("final_rot_err_deg", r.final_rot_err_deg);
    j.set("final_trans_err_cm", r.final_trans_err_cm);
    j.set("trials", r.trials);
    j.set("moved_cm", r.moved_cm);
    j.set("turned_deg", r.turned_deg);
    j.set("trial_success", Json::arrayOf(r.trial_success));
    j.set("trial_final_rot_err_deg", Json::arrayOf(r.trial_final_rot_err_deg));
    j.set("trial_final_trans_err_cm", Json::arrayOf(r.trial_final_trans_err_cm));
    j.set("trial_visibility", Json::arrayOf(r.trial_visibility));
    j.set("trial_moved_cm", Json::arrayOf(r.trial_moved_cm));
    j.set("trial_turned_deg", Json::arrayOf(r.trial_turned_deg));
    j.set("trial_tilt_deg", Json::arrayOf(r.trial_tilt_deg));
    j.set("trial_outcome", Json::arrayOf(r.trial_outcome));
    j.set("trial_min_visibility", Json::arrayOf(r.trial_min_visibility));
    j.set("trial_final_status", Json::arrayOf(r.trial_final_status));
    if (o.probe_every > 0) {
      j.set("probes", static_cast<double>(r.probe_rot_err_deg.size()));
      j.set("probe_rot_err_deg_mean", r.probe_rot_mean_deg);
      j.set("probe_rot_err_deg_p90", r.probe_rot_p90_deg);
      j.set("probe_trans_err_cm_mean", r.probe_trans_mean_cm);
    }
    rows.push(std::move(j));
  }
  doc.set("rows", std::move(rows));
  return doc;
}

Pose physicsMotion(sim::World& shadow, const sim::PowderField& powder, const Pose& T_from,
                   const std::vector<sim::ArmState>& steps, double dt) {
  shadow.powder() = powder;
  shadow.setPartPose(0, T_from);  // at rest: the frame's motion is the nozzle's doing
  for (const sim::ArmState& s : steps) {
    shadow.setArm(s);
    shadow.step(dt);
  }
  return shadow.partTruth(0).T_cell_part * T_from.inverse();
}

void powderFromScan(sim::PowderField& powder, const Cloud& scan, const Pose* T_cell_nozzle,
                    const Eigen::AlignedBox3d& box_part, const Pose& T_cell_part, double margin) {
  const Pose T_part_cell = T_cell_part.inverse(Eigen::Isometry);
  const Eigen::AlignedBox3d near(box_part.min().array() - margin, box_part.max().array() + margin);
  const Pose T_nozzle_cell = T_cell_nozzle ? T_cell_nozzle->inverse(Eigen::Isometry) : Pose::Identity();
  // The nozzle's body (25 cm of it, 1.25 cm radius) and 2 cm past its ends and 1.25 cm round it.
  constexpr double kLength = 0.25, kRadius = 0.0125, kAlong = 0.02, kAround = 0.0125;
  std::unordered_map<std::size_t, std::vector<double>> columns;
  for (const Point& p : scan) {
    if (near.contains(T_part_cell * p)) continue;
    if (T_cell_nozzle && onNozzleBody(T_nozzle_cell * p, kLength, kRadius, kAlong, kAround)) continue;
    int i = 0, j = 0;
    if (powder.cellOf(p.head<2>(), i, j)) columns[powder.index(i, j)].push_back(p.z());
  }
  for (auto& [c, z] : columns) {
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    powder.setHeight(c, z[z.size() / 2]);
  }
}

Pose oracleMotion(const Pose& T_a, const Pose& T_b, MotionPart part, double fraction) {
  const Eigen::Matrix3d R = T_b.linear() * T_a.linear().transpose();
  const Eigen::Vector3d a = T_a.translation();
  Eigen::Vector3d b = T_b.translation();
  const Eigen::Matrix3d planar_turn =
      Eigen::AngleAxisd(turnAboutVertical(R), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::AngleAxisd turn(R);
  if (part == MotionPart::kPlanar) {
    turn = Eigen::AngleAxisd(planar_turn);
    b.z() = a.z();
  } else if (part == MotionPart::kTip) {
    turn = Eigen::AngleAxisd(Eigen::Matrix3d(R * planar_turn.transpose()));  // R = tip x planar turn
    b.head<2>() = a.head<2>();
  }
  Pose out = Pose::Identity();  // about the part's origin a: a -> a + fraction (b - a)
  out.linear() = Eigen::AngleAxisd(fraction * turn.angle(), turn.axis()).toRotationMatrix();
  out.translation() = a + fraction * (b - a) - out.linear() * a;
  return out;
}

}  // namespace depowder::eval
