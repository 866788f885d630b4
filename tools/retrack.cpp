// depowder-retrack: tracks the POINTS of a recorded run again, in process, with this build's
// tracker and a cell's settings (optionally changed with --set), and compares every frame with
// the run's SIM_TRUTH. Deterministic and faster than real time: the way to try a tracker change
// on a recorded fall or push before running the cell. The planner does not see the new poses,
// so the nozzle moves as it did in the recording.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <vector>

#include "depowder/clock.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/log_time.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "depowder/stats.hpp"
#include "depowder/waypoint_t.hpp"
#include "tracker_node.hpp"

using namespace depowder;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-retrack: " << error << "\n";
  std::cerr
      << "usage: depowder-retrack RUN.lcmlog --cell CELL.yaml [--set tracker.KEY=VALUE]... [--every S]\n"
         "                        [--from S] [--to S] [--prefix P]\n"
         "  Tracks the log's POINTS frames with the cell's tracker settings (--set changes one, as\n"
         "  depowder-eval's --set: icp.tangent_weight=0) and prints, every S seconds of the run\n"
         "  (default 5; 0: every frame), each part's status and its error against SIM_TRUTH (with the\n"
         "  error's rotation axis and translation in the part frame), the fit's inlier ratio and RMS, P_cad against\n"
         "  the cameras' lines of sight (sight seen/in front/hidden samples), the nozzle's tool and tip\n"
         "  (cell axes, from the part's origin), MOVING while the filter takes the part for moving\n"
         "  (filter.moving_translation), FALLING while it takes it for falling (filter.fall_sink),\n"
         "  REFIT when the refit replaced the pose, RESET when the filter started again\n"
         "  (filter.reset_frames) and TEMPLATE when the template was derived again (Alg. 1, line 13); then\n"
         "  the error percentiles over the frames that reported TRACKING.\n"
         "  Times are seconds from the first POINTS frame along the log's event times, with the steps of\n"
         "  the recording host's clock taken out as depowder-logmend does; stderr names each step.\n"
         "  Exit 1 if the log has no POINTS frame or no truth.\n";
  return error.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help") return usage(argc < 2 ? "missing RUN.lcmlog" : "");
  const std::string log_path = argv[1];
  std::string cell_path, prefix;
  std::vector<std::pair<std::string, double>> sets;
  double every = 5, from = 0, to = INFINITY;
  try {
    for (int i = 2; i < argc; ++i) {
      const std::string a = argv[i];
      if (i + 1 >= argc) return usage("missing value after " + a);
      const std::string v = argv[++i];
      if (a == "--cell") {
        cell_path = v;
      } else if (a == "--prefix") {
        prefix = v;
      } else if (a == "--every") {
        every = std::stod(v);
      } else if (a == "--from") {
        from = std::stod(v);
      } else if (a == "--to") {
        to = std::stod(v);
      } else if (a == "--set") {
        const std::size_t eq = v.find('=');
        if (eq == std::string::npos) return usage("--set needs KEY=VALUE, got '" + v + "'");
        std::string key = v.substr(0, eq);
        if (key.rfind("tracker.", 0) == 0) key = key.substr(8);
        sets.emplace_back(key, std::stod(v.substr(eq + 1)));
      } else {
        return usage("unknown option " + a);
      }
    }
  } catch (const std::exception&) {
    return usage("a number was expected");
  }
  if (cell_path.empty()) return usage("--cell is required (the cell the run was recorded with)");
  try {
    const node::CellConfig cell = node::loadCell(cell_path);
    tracker::TrackerNodeOptions options = tracker::readTrackerOptions(cell);
    for (const auto& [key, value] : sets) tracker::setField(options.tracker, key, value);
    options.threads = 1;  // deterministic and one core: the frames come from the file, not a clock
    tracker::TrackerNode node(cell, options);

    // Seconds along the run: the log's event times with the recording clock's steps taken out, so
    // that the frames after a step back are not before the start.
    const node::LogTimes times = node::mendLogTimes(log_path, prefix + "HEARTBEAT");
    for (const node::LogGap& gap : times.gaps) std::cerr << "depowder-retrack: " << times.describe(gap) << "\n";
    for (const node::LogDamage& d : times.damage) std::cerr << "depowder-retrack: " << node::describe(d) << "\n";
    node::LogReader log(log_path);
    std::map<std::string, Pose> truth;  // the newest SIM_TRUTH at or before the frame
    bool have_truth = false;
    Point nozzle = Point::Constant(NAN);  // its tip, cell frame, and its tool at the newest SIM_TRUTH
    int tool = 0;
    std::int64_t start = 0, frames = 0, bad = 0;  // start: the first frame's event time, mended
    double next_print = from;
    std::map<std::string, std::vector<double>> rot, trans;
    std::map<std::string, std::map<std::string, int>> statuses;
    std::map<std::string, std::pair<double, double>> last;       // deg, cm
    std::map<std::string, int> refits, resets, moving, falling;  // frames, per part
    std::size_t event = 0;                                       // its index in the log
    for (const lcm::LogEvent* e; event < times.utime.size() && (e = log.next()) != nullptr; ++event) {
      if (e->channel == prefix + "SIM_TRUTH") {
        sim_truth_t m;
        if (m.decode(e->data, 0, e->datalen) < 0) {
          ++bad;
          continue;
        }
        for (const auto& p : m.parts)
          if (const auto T = node::fromMsg(p.T_cell_part)) truth[p.part] = *T;
        if (const auto T = node::fromMsg(m.T_cell_nozzle)) nozzle = T->translation();
        tool = m.tool;
        have_truth = true;
      } else if (e->channel == prefix + "POINTS") {
        point_cloud_t m;
        if (m.decode(e->data, 0, e->datalen) < 0) {
          ++bad;
          continue;
        }
        if (frames == 0) start = times.utime[event];
        const double t = secondsBetween(times.utime[event], start);
        if (t > to) break;
        // Every frame is tracked, also before --from: the tracker's state depends on them all.
        const std::vector<part_pose_t> poses = node.onPoints(m, times.utime[event]);
        ++frames;
        const bool print = t >= from && (every <= 0 || t >= next_print);
        if (print) next_print = t + every;
        for (std::size_t k = 0; k < poses.size(); ++k) {
          const part_pose_t& p = poses[k];
          const tracker::TrackResult* result = k < node.lastResults().size() ? &node.lastResults()[k] : nullptr;
          if (result && result->refit) ++refits[p.part];
          if (result && result->reset) ++resets[p.part];
          if (result && result->moving) ++moving[p.part];
          if (result && result->falling) ++falling[p.part];
          const auto T = node::fromMsg(p.T_cell_part);
          const auto truth_it = truth.find(p.part);
          if (!T || truth_it == truth.end() || t < from) continue;
          const double dr = rotationDistanceDeg(*T, truth_it->second);
          const double dt = 100 * translationDistance(*T, truth_it->second);
          static const char* names[] = {"waiting", "tracking", "degraded", "lost"};
          const std::string status = p.status >= 0 && p.status < 4 ? names[p.status] : "?";
          ++statuses[p.part][status];
          last[p.part] = {dr, dt};
          if (p.status == part_pose_t::TRACKING) rot[p.part].push_back(dr), trans[p.part].push_back(dt);
          if (print) {
            // The error's rotation axis and translation in the part frame: a spin about a symmetry
            // axis, or a part sitting high, shows here.
            const Pose E = truth_it->second.inverse(Eigen::Isometry) * *T;
            const Eigen::AngleAxisd aa(E.linear());
            const Eigen::Vector3d err_mm = 1000 * E.translation();
            const Eigen::Vector3d nozzle_mm = 1000 * (nozzle - truth_it->second.translation());  // from the part
            // P_cad against the lines of sight, on the frames the refit ran ("-" on the others).
            std::string sight = "-";
            if (result && result->sight.total() > 0) {
              const tracker::SightCheck& c = result->sight;
              sight = std::to_string(c.seen) + "/" + std::to_string(c.in_front) + "/" + std::to_string(c.hidden);
            }
            std::printf(
                "%7.2f s  %-10s %-8s eta %.3f  err %6.2f deg about (%+.2f %+.2f %+.2f) %5.2f cm (%+.1f %+.1f %+.1f mm) "
                " "
                "inliers %.2f rms %.2f mm  sight %s  nozzle %s %+.0f %+.0f %+.0f mm%s%s%s%s%s  %s\n",
                t, p.part.c_str(), status.c_str(), p.eta, dr, aa.axis().x(), aa.axis().y(), aa.axis().z(), dt,
                err_mm.x(), err_mm.y(), err_mm.z(), p.inlier_ratio, 1e3 * p.fitness, sight.c_str(),
                tool == waypoint_t::TOOL_AIR      ? "air"
                : tool == waypoint_t::TOOL_VACUUM ? "vac"
                                                  : "off",
                nozzle_mm.x(), nozzle_mm.y(), nozzle_mm.z(), result && result->moving ? " MOVING" : "",
                result && result->falling ? " FALLING" : "", result && result->refit ? " REFIT" : "",
                result && result->reset ? " RESET" : "", result && result->template_updated ? " TEMPLATE" : "",
                p.status_reason.c_str());
          }
        }
      }
    }
    if (bad) std::cerr << "depowder-retrack: " << bad << " undecodable messages skipped\n";
    if (frames == 0 || !have_truth) {
      std::cerr << "depowder-retrack: " << log_path << " has " << (frames == 0 ? "no POINTS frame" : "no SIM_TRUTH")
                << " (channel prefix '" << prefix << "')\n";
      return 1;
    }
    std::printf("%lld frames tracked\n", static_cast<long long>(frames));
    for (const auto& [part, counts] : statuses) {
      std::printf("%s: moving %d, falling %d, refits %d, resets %d,", part.c_str(), moving[part], falling[part],
                  refits[part], resets[part]);
      for (const auto& [status, n] : counts) std::printf(" %s %d", status.c_str(), n);
      const auto& r = rot[part];
      const auto& d = trans[part];
      std::printf(
          "\n  while tracking: rotation p50 %.2f p95 %.2f max %.2f deg, translation p50 %.2f p95 %.2f max %.2f cm\n",
          percentile(r, 0.5), percentile(r, 0.95), r.empty() ? NAN : *std::max_element(r.begin(), r.end()),
          percentile(d, 0.5), percentile(d, 0.95), d.empty() ? NAN : *std::max_element(d.begin(), d.end()));
      std::printf("  last frame: %.2f deg, %.2f cm\n", last[part].first, last[part].second);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "depowder-retrack: " << e.what() << "\n";
    return 2;
  }
}
