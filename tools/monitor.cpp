// depowder-monitor: watches a running cell over LCM, shows a live line per part
// (phase, eta, tracking status, elapsed time) and, when every part is done, prints
// the run's summary: time, final true eta, pose error, contacts, the controller's errors and
// the driver's faults, frames dropped, end-to-end latency, and each process's CPU and peak memory.
// It only listens; SIM_TRUTH is read for the report, never fed back to the cell.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "depowder/clock.hpp"
#include "depowder/eval/json.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "depowder/stats.hpp"
#include "run_end.hpp"

using namespace depowder;

namespace {

struct PartView {
  part_pose_t pose{};
  progress_t progress{};
  part_truth_t truth{};
  bool has_pose = false, has_progress = false, has_truth = false;
  std::int64_t poses = 0;
  tools::PartEnd end;  // DONE since when, tracked and true poses still since when (node::steadyUtime)
};

const char* phaseName(int phase) {
  switch (phase) {
    case progress_t::PHASE_VACUUM_BURIED:
      return "1 vacuum (initial pose)";
    case progress_t::PHASE_VACUUM_TRACKED:
      return "2 vacuum (tracked)";
    case progress_t::PHASE_AIR_BLAST:
      return "3 air blast";
    case progress_t::PHASE_DONE:
      return "done";
    default:
      return "-";
  }
}

const char* trackName(int s) {
  static const char* names[] = {"waiting", "tracking", "degraded", "lost"};
  return s >= 0 && s <= 3 ? names[s] : "?";
}

// One process (a name on a host) over the run. One restarted (a new pid) counts from 0 again:
// what its earlier runs had counted is kept, so the summary covers the whole run.
struct ProcessView {
  heartbeat_t last{};
  int restarts = 0;
  std::int64_t dropped = 0, decode_errors = 0;  // of its earlier runs
  std::map<std::string, double> stats;          // of its earlier runs
  std::int64_t peak_rss_kb = 0;
  double cpu_sum = 0;  // over all heartbeats: the mean is the run's
  int beats = 0;
  std::chrono::steady_clock::time_point heard;

  void take(const heartbeat_t& m) {
    if (beats > 0 && m.pid != last.pid) {
      ++restarts;
      dropped += last.dropped;
      decode_errors += last.decode_errors;
      for (int i = 0; i < last.num_stats; ++i) stats[last.stat_names[i]] += last.stat_values[i];
    }
    last = m;
    peak_rss_kb = std::max(peak_rss_kb, m.peak_rss_kb);
    cpu_sum += m.cpu_percent;
    ++beats;
    heard = std::chrono::steady_clock::now();
  }
  /// A counter over the whole run; NaN if never heard.
  double total(const std::string& name) const {
    const auto before = stats.find(name);
    const double now = node::heartbeatStat(last, name);
    if (before == stats.end()) return now;
    return before->second + (std::isnan(now) ? 0 : now);
  }
};

// A figure of `process` (summed over the hosts it runs on): a counter over the whole run, or the
// latest value if not `cumulative`; -1 when that process or that stat was not heard.
std::int64_t counter(const std::map<std::pair<std::string, std::string>, ProcessView>& processes,
                     const std::string& process, const std::string& name, bool cumulative = true) {
  double sum = NAN;
  for (const auto& [key, view] : processes) {
    if (key.first != process) continue;
    const double v = cumulative ? view.total(name) : node::heartbeatStat(view.last, name);
    if (!std::isnan(v)) sum = (std::isnan(sum) ? 0 : sum) + v;
  }
  return std::isnan(sum) ? -1 : static_cast<std::int64_t>(sum);
}

// A value in summary.json, written by the evaluation's JSON writer: null where a number is not
// known (NaN: no truth on a real cell, no pose, no latency measured; `<<` once wrote "nan", which
// is not JSON), and a name from the bus escaped.
std::string jsonValue(const eval::Json& value) { return value.dump(0); }

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-monitor: " << error << "\n";
  std::cerr << "usage: depowder-monitor [--parts N] [--timeout S] [--summary FILE.json] [--cell FILE] [--url URL] "
               "[--prefix P]\n"
               "  Exits 0 when every part is done (held 1 s, and at rest: tracked and true poses still for\n"
               "  1 s, or 10 s after done at the latest) with no nozzle-part contact; 1 on timeout or\n"
               "  contact; --parts N waits until N parts have been heard of (default 1). The bus is the\n"
               "  cell file's (lcm section; default: the default cell) unless --url / --prefix.\n";
  return error.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell, summary_file;
  std::optional<std::string> url, prefix;
  double timeout_s = 600;
  std::size_t expected_parts = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (i + 1 >= argc) return usage("missing value after " + a);
    if (a == "--timeout")
      timeout_s = std::atof(argv[++i]);
    else if (a == "--parts")
      expected_parts = static_cast<std::size_t>(std::max(1, std::atoi(argv[++i])));
    else if (a == "--summary")
      summary_file = argv[++i];
    else if (a == "--cell")
      cell = argv[++i];
    else if (a == "--url")
      url = argv[++i];
    else if (a == "--prefix")
      prefix = argv[++i];
    else
      return usage("unknown option " + a);
  }

  try {
    node::installShutdownHandlers();
    const node::LcmConfig lcm = node::toolBus("depowder-monitor", cell, url, prefix);
    node::Bus bus(lcm.url, lcm.prefix);
    std::map<std::string, PartView> parts;
    std::map<std::pair<std::string, std::string>, ProcessView> processes;  // by process name and host
    robot_state_t robot{};
    sim_truth_t truth{};
    bool has_truth = false;
    std::vector<double> plan_latency_ms, pose_latency_ms;
    std::vector<double> progress_latency_ms, new_plan_latency_ms;  // the PROGRESS step; plans that are not refreshes
    std::int64_t points_seen = 0, points_lost = 0, last_seq = -1, plans = 0;
    std::set<std::int64_t> points_utimes;  // POINTS frames, to find PART_POSE frames that never came
    std::map<std::string, std::set<std::int64_t>> pose_utimes;

    bus.subscribe<point_cloud_t>("POINTS", [&](const point_cloud_t& m, const std::string&) {
      ++points_seen;
      if (last_seq >= 0 && m.seq > last_seq + 1) points_lost += m.seq - last_seq - 1;
      last_seq = m.seq;
      points_utimes.insert(m.utime);
    });
    bus.subscribe<part_pose_t>("PART_POSE", [&](const part_pose_t& m, const std::string&) {
      PartView& p = parts[m.part];
      p.pose = m;
      p.has_pose = true;
      ++p.poses;
      if (const std::optional<Pose> T = node::fromMsg(m.T_cell_part)) p.end.tracked.see(*T, node::steadyUtime());
      pose_utimes[m.part].insert(m.utime);
      pose_latency_ms.push_back(secondsBetween(node::nowUtime(), m.utime) * 1e3);
    });
    bus.subscribe<progress_t>("PROGRESS", [&](const progress_t& m, const std::string&) {
      PartView& p = parts[m.part];
      p.progress = m;
      p.has_progress = true;
      if (m.utime > 0) progress_latency_ms.push_back(secondsBetween(node::nowUtime(), m.utime) * 1e3);
      if (m.phase == progress_t::PHASE_DONE && p.end.done_since_us == 0) p.end.done_since_us = node::steadyUtime();
      if (m.phase != progress_t::PHASE_DONE) p.end.done_since_us = 0;
    });
    nozzle_plan_t plan{};  // the latest plan, named when a contact begins
    const auto start = std::chrono::steady_clock::now();
    bus.subscribe<sim_truth_t>("SIM_TRUTH", [&](const sim_truth_t& m, const std::string&) {
      truth = m;
      has_truth = true;
      for (const auto& t : m.parts) {
        PartView& p = parts[t.part];
        if (t.nozzle_contact && !(p.has_truth && p.truth.nozzle_contact)) {
          // A contact begins: say when, and what the cell believed then, so it can be traced.
          const auto est = node::fromMsg(p.pose.T_cell_part), tru = node::fromMsg(t.T_cell_part);
          const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          std::printf(
              "\n[%6.1f s] CONTACT with %s: plan %lld (%s), robot %s, tracked pose %s off by %.1f deg %.1f mm\n", s,
              t.part.c_str(), static_cast<long long>(plan.plan_id), plan.reason.c_str(), robot.mode_reason.c_str(),
              p.has_pose ? trackName(p.pose.status) : "none",
              p.has_pose && est && tru ? rotationDistanceDeg(*est, *tru) : NAN,
              p.has_pose && est && tru ? translationDistance(*est, *tru) * 1000 : NAN);
          std::fflush(stdout);
        }
        p.truth = t;
        p.has_truth = true;
        if (const std::optional<Pose> T = node::fromMsg(t.T_cell_part)) p.end.truth.see(*T, node::steadyUtime());
      }
    });
    bus.subscribe<nozzle_plan_t>("NOZZLE_PLAN", [&](const nozzle_plan_t& m, const std::string&) {
      plan = m;
      ++plans;
      if (m.utime > 0) {
        plan_latency_ms.push_back(secondsBetween(node::nowUtime(), m.utime) * 1e3);
        if (m.reason.rfind("refresh: ", 0) != 0) new_plan_latency_ms.push_back(plan_latency_ms.back());
      }
    });
    bus.subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t& m, const std::string&) { robot = m; });
    bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& m, const std::string&) {
      processes[{m.process, m.host}].take(m);
    });

    const bool tty = isatty(STDOUT_FILENO);
    auto last_line = start;
    bool done = false, timed_out = false;
    double elapsed = 0;
    while (!node::shutdownRequested()) {
      bus.spinOnce(20);
      const auto now = std::chrono::steady_clock::now();
      elapsed = std::chrono::duration<double>(now - start).count();
      std::size_t n_done = 0;
      for (const auto& [name, p] : parts)
        if (p.end.finished(node::steadyUtime())) ++n_done;
      if (parts.size() >= expected_parts && n_done == parts.size()) {
        done = true;
        break;
      }
      if (elapsed > timeout_s) {
        timed_out = true;
        break;
      }
      if (now - last_line >= std::chrono::milliseconds(tty ? 250 : 5000)) {
        last_line = now;
        std::string line;
        char buf[256];
        std::snprintf(buf, sizeof(buf), "[%6.1f s]", elapsed);
        line = buf;
        for (const auto& [name, p] : parts) {
          // In phase 3 the planner may still vacuum below the part first (planner.vacuum.undercut).
          const bool undercut = plan.part == name && plan.reason.find("undercut: ") != std::string::npos;
          std::snprintf(buf, sizeof(buf), " %s: phase %s%s, eta %3.0f%% (true %3.0f%%), %s |", name.c_str(),
                        p.has_progress ? phaseName(p.progress.phase) : "-", undercut ? " (undercut: vacuum first)" : "",
                        p.has_progress ? 100 * p.progress.eta : NAN, p.has_truth ? 100 * p.truth.eta : NAN,
                        p.has_pose ? trackName(p.pose.status) : "no pose");
          line += buf;
        }
        std::snprintf(buf, sizeof(buf), " plans %lld, contacts %d", static_cast<long long>(plans),
                      has_truth ? truth.contact_count : 0);
        line += buf;
        std::cout << (tty ? "\r\033[K" : "") << line << (tty ? "" : "\n") << std::flush;
      }
    }
    if (tty) std::cout << "\n";

    // Frames the tracker never answered (the last second's may still be in flight).
    std::int64_t poses_missing = 0;
    const std::int64_t settle = points_utimes.empty() ? 0 : *points_utimes.rbegin() - 1000000;
    for (const auto& [name, got] : pose_utimes)
      for (const std::int64_t u : points_utimes)
        if (u < settle && u >= *got.begin() && !got.count(u)) ++poses_missing;

    std::ostringstream json;
    json << "{\n  \"done\": " << (done ? "true" : "false") << ",\n  \"elapsed_s\": " << elapsed << ",\n  \"parts\": [";
    std::printf("\n=== depowder run summary ===\n%s after %.1f s\n",
                done        ? "All parts done"
                : timed_out ? "TIMED OUT"
                            : "Interrupted",
                elapsed);
    bool first = true;
    for (const auto& [name, p] : parts) {
      double rot = NAN, trans = NAN;
      if (p.has_pose && p.has_truth) {
        const auto est = node::fromMsg(p.pose.T_cell_part), tru = node::fromMsg(p.truth.T_cell_part);
        if (est && tru) {
          rot = rotationDistanceDeg(*est, *tru);
          trans = translationDistance(*est, *tru) * 100;
        }
      }
      const bool at_rest = p.end.atRest(node::steadyUtime());
      std::printf("  %-10s phase %-24s eta %5.1f%%  true eta %5.1f%%  pose error %.2f deg %.2f cm  (%s%s)\n",
                  name.c_str(), phaseName(p.progress.phase), 100 * p.progress.eta, 100 * p.truth.eta, rot, trans,
                  trackName(p.pose.status), at_rest ? "" : "; still moving");
      json << (first ? "\n" : ",\n") << "    {\"part\": " << jsonValue(name) << ", \"phase\": " << int(p.progress.phase)
           << ", \"eta\": " << jsonValue(p.progress.eta)
           << ", \"true_eta\": " << jsonValue(p.has_truth ? p.truth.eta : NAN)
           << ", \"rot_err_deg\": " << jsonValue(rot) << ", \"trans_err_cm\": " << jsonValue(trans)
           << ", \"at_rest\": " << (at_rest ? "true" : "false") << "}";
      first = false;
    }
    const int contacts = has_truth ? truth.contact_count : -1;
    std::printf("  nozzle-part contacts: %d\n", contacts);
    // The arm: what the (emulated) controller refused, and what the driver did about it (-: not heard).
    const std::vector<std::pair<std::string, std::int64_t>> arm = {
        {"controller_late_errors", counter(processes, "depowder-sim", "controller_late_errors")},
        {"controller_limit_errors", counter(processes, "depowder-sim", "controller_limit_errors")},
        {"controller_speed_errors", counter(processes, "depowder-sim", "controller_speed_errors")},
        {"driver_faults", counter(processes, "depowder-driver", "faults")},
        {"driver_safety_stops", counter(processes, "depowder-driver", "safety_stops")},
        {"driver_estops", counter(processes, "depowder-driver", "estops")},
        {"driver_reconnects", counter(processes, "depowder-driver", "reconnects")},
        {"driver_realtime", counter(processes, "depowder-driver", "realtime", false)}};  // 1: slave loop SCHED_FIFO
    auto shown = [](std::int64_t n) { return n < 0 ? std::string("-") : std::to_string(n); };
    std::printf(
        "  controller errors: slvMove late %s, joint limit %s, too fast %s; driver faults %s, safety stops %s, "
        "E-stops %s, reconnects %s; slave loop SCHED_FIFO %s\n",
        shown(arm[0].second).c_str(), shown(arm[1].second).c_str(), shown(arm[2].second).c_str(),
        shown(arm[3].second).c_str(), shown(arm[4].second).c_str(), shown(arm[5].second).c_str(),
        shown(arm[6].second).c_str(),
        arm[7].second < 0 ? "-"
        : arm[7].second   ? "yes"
                          : "no");
    std::printf("  POINTS seen %lld, lost %lld; PART_POSE frames missing %lld\n", static_cast<long long>(points_seen),
                static_cast<long long>(points_lost), static_cast<long long>(poses_missing));
    std::printf(
        "  latency depth->PART_POSE p50 %.1f p99 %.1f ms; depth->NOZZLE_PLAN p50 %.1f p99 %.1f ms (%zu plans)\n",
        percentile(pose_latency_ms, 0.5), percentile(pose_latency_ms, 0.99), percentile(plan_latency_ms, 0.5),
        percentile(plan_latency_ms, 0.99), plan_latency_ms.size());
    std::printf(
        "  of which depth->PROGRESS p50 %.1f p99 %.1f ms; new plans (not refreshes) p50 %.1f p99 %.1f ms (%zu)\n",
        percentile(progress_latency_ms, 0.5), percentile(progress_latency_ms, 0.99),
        percentile(new_plan_latency_ms, 0.5), percentile(new_plan_latency_ms, 0.99), new_plan_latency_ms.size());
    // The machine's load (other jobs share the cores): latency figures mean little without it.
    double load[3];
    std::ifstream loadavg("/proc/loadavg");
    if (!(loadavg >> load[0] >> load[1] >> load[2])) load[0] = load[1] = load[2] = -1;  // -1: not known
    std::printf("  machine load average 1 / 5 / 15 min: %.2f / %.2f / %.2f\n", load[0], load[1], load[2]);
    std::printf("  %-22s %6s %9s %8s %7s %8s\n", "process", "cpu%", "peak_MB", "dropped", "decode", "restarts");
    json << "\n  ],\n  \"contacts\": " << contacts;
    for (const auto& [key, n] : arm) json << ",\n  \"" << key << "\": " << n;
    json << ",\n  \"points_lost\": " << points_lost << ",\n  \"part_pose_missing\": " << poses_missing
         << ",\n  \"points_seen\": " << points_seen
         << ",\n  \"pose_latency_ms_p50\": " << jsonValue(percentile(pose_latency_ms, 0.5))
         << ",\n  \"pose_latency_ms_p99\": " << jsonValue(percentile(pose_latency_ms, 0.99))
         << ",\n  \"plan_latency_ms_p50\": " << jsonValue(percentile(plan_latency_ms, 0.5))
         << ",\n  \"plan_latency_ms_p99\": " << jsonValue(percentile(plan_latency_ms, 0.99))
         << ",\n  \"progress_latency_ms_p99\": " << jsonValue(percentile(progress_latency_ms, 0.99))
         << ",\n  \"new_plan_latency_ms_p99\": " << jsonValue(percentile(new_plan_latency_ms, 0.99))
         << ",\n  \"load_average\": [" << load[0] << ", " << load[1] << ", " << load[2] << "],\n  \"processes\": {";
    first = true;
    // Named by process, and by host too where one name runs on several. CPU is the run's mean;
    // a process not heard in its last 3 s at the end (crashed, hung) says for how long.
    std::map<std::string, int> hosts_of;
    for (const auto& [key, view] : processes) ++hosts_of[key.first];
    const auto end = std::chrono::steady_clock::now();
    for (const auto& [key, h] : processes) {
      const std::string name = hosts_of[key.first] > 1 ? key.first + "@" + key.second : key.first;
      const double cpu = h.cpu_sum / std::max(h.beats, 1);
      const double silent_s = std::chrono::duration<double>(end - h.heard).count();
      const std::int64_t dropped = h.dropped + h.last.dropped, decode = h.decode_errors + h.last.decode_errors;
      std::printf("  %-22s %6.1f %9.1f %8lld %7lld %8d", name.c_str(), cpu, h.peak_rss_kb / 1024.0,
                  static_cast<long long>(dropped), static_cast<long long>(decode), h.restarts);
      if (silent_s > 3) std::printf("  silent for the last %.1f s", silent_s);
      std::printf("\n");
      json << (first ? "\n" : ",\n") << "    " << jsonValue(name) << ": {\"cpu_percent\": " << jsonValue(cpu)
           << ", \"peak_rss_mb\": " << h.peak_rss_kb / 1024.0 << ", \"dropped\": " << dropped
           << ", \"restarts\": " << h.restarts << ", \"silent_s\": " << jsonValue(silent_s) << "}";
      first = false;
    }
    json << "\n  }\n}\n";
    if (!summary_file.empty()) std::ofstream(summary_file) << json.str();
    std::fflush(stdout);
    return done && contacts <= 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "depowder-monitor: " << e.what() << "\n";
    return 2;
  }
}
