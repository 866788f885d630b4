// fault_probe: the fault tests' instrument (test/faults.sh). Three jobs:
//   wait COND      block until the live cell reaches COND (tracking | vacuum); print its utime
//   garbage        publish random bytes, messages of the wrong type and oversized messages on
//                  every depowder channel for a bounded time
//   future         publish one camera frame again, stamped far in the future
//   report CASE    read the run's LCM log and print what the fault did (stop times, gaps, jumps,
//                  restarts, decode errors), then check it against the limits stated below;
//                  exit 1 if a check fails
// Times are wall-clock microseconds (the utime of every depowder message). After a step of the
// host's system clock (--step), the stamps taken after it are put back on the clock before it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "depowder/depth_image_t.hpp"
#include "depowder/estop_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/launcher_status_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/log_time.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "depowder/waypoint_t.hpp"
#include "driver_config.hpp"

using namespace depowder;

namespace {

int usage() {
  std::cerr << "usage: fault_probe wait tracking|vacuum [--timeout S]\n"
               "       fault_probe garbage [--seconds S] [--rate HZ] [--seed N]\n"
               "       fault_probe future [--ahead S]\n"
               "       fault_probe report CASE LOG --cell FILE --at UTIME [--until UTIME] [--step S]\n"
               "  CASE: tracker_killed | link_cut | estop | garbage | camera_silent | controller_drop | clock_jump |\n"
               "        clock_step (the host's system clock stepped S seconds at UTIME, and back at --until)\n";
  return 2;
}

// ---------------------------------------------------------------- wait
int waitFor(const std::string& cond, double timeout_s) {
  node::Bus bus;
  std::int64_t met = 0;
  bus.subscribe<part_pose_t>("PART_POSE", [&](const part_pose_t& m, const std::string&) {
    if (cond == "tracking" && m.status == part_pose_t::TRACKING) met = m.utime;
  });
  bus.subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t& m, const std::string&) {
    if (cond == "vacuum" && m.mode == robot_state_t::MODE_FOLLOWING && m.tool == waypoint_t::TOOL_VACUUM) met = m.utime;
  });
  if (!bus.spinUntil([&] { return met != 0; }, timeout_s))
    return std::cerr << "fault_probe: no '" << cond << "' within " << timeout_s << " s\n", 1;
  std::cout << met << std::endl;
  return 0;
}

// ---------------------------------------------------------------- garbage
int garbage(double seconds, double rate_hz, unsigned seed) {
  node::Bus bus;
  const std::vector<std::string> channels = {"DEPTH_LEFT", "DEPTH_RIGHT", "POINTS",      "PART_POSE",
                                             "PROGRESS",   "NOZZLE_PLAN", "ROBOT_STATE", "ESTOP",
                                             "HEARTBEAT",  "LAUNCHER",    "SIM_TRUTH"};
  std::mt19937 rng(seed);
  // A well-formed message of another type: decodes nowhere but on its own channel.
  heartbeat_t wrong;
  wrong.utime = node::nowUtime();
  wrong.process = "fault_probe";
  std::vector<std::uint8_t> wrong_bytes(wrong.getEncodedSize());
  wrong.encode(wrong_bytes.data(), 0, static_cast<int>(wrong_bytes.size()));
  progress_t other;
  std::vector<std::uint8_t> other_bytes(other.getEncodedSize());
  other.encode(other_bytes.data(), 0, static_cast<int>(other_bytes.size()));
  std::int64_t sent = 0, bytes = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  const auto period = std::chrono::duration<double>(1.0 / rate_hz);
  auto next = std::chrono::steady_clock::now();
  // Every round, on every channel, one of: random bytes, a valid message of the wrong type, a
  // right fingerprint with a corrupt body; and one oversized message (1 MB, more than any depowder
  // message) on one channel in turn.
  for (int k = 0; std::chrono::steady_clock::now() < end; ++k) {
    for (const std::string& ch : channels) {
      std::vector<std::uint8_t> msg;
      switch (k % 3) {
        case 0:  // random bytes, 1 B .. 4 kB
          msg.resize(1 + rng() % 4096);
          for (auto& b : msg) b = static_cast<std::uint8_t>(rng());
          break;
        case 1:  // a valid message of the wrong type (HEARTBEAT gets a progress_t)
          msg = ch == "HEARTBEAT" ? other_bytes : wrong_bytes;
          break;
        case 2:  // a right fingerprint followed by garbage (truncated / corrupt body)
          msg = ch == "HEARTBEAT" ? wrong_bytes : other_bytes;
          msg.resize(8 + rng() % 64);
          for (std::size_t i = 8; i < msg.size(); ++i) msg[i] = static_cast<std::uint8_t>(rng());
          break;
      }
      bus.publishRaw(ch, msg.data(), static_cast<int>(msg.size()));
      ++sent;
      bytes += static_cast<std::int64_t>(msg.size());
    }
    std::vector<std::uint8_t> big(1 << 20);
    for (auto& b : big) b = static_cast<std::uint8_t>(rng());
    bus.publishRaw(channels[k % channels.size()], big.data(), static_cast<int>(big.size()));
    ++sent;
    bytes += static_cast<std::int64_t>(big.size());
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  std::cout << "garbage: " << sent << " messages, " << bytes / 1000000.0 << " MB on " << channels.size()
            << " channels in " << seconds << " s" << std::endl;
  return 0;
}

// ---------------------------------------------------------------- future
// The next DEPTH_LEFT frame published once more, stamped `ahead_s` later: a camera whose clock
// glitched, or a host whose clock is wrong. Prints the wall utime it went out.
int future(double ahead_s) {
  node::Bus bus;
  std::optional<depth_image_t> frame;
  bus.subscribe<depth_image_t>("DEPTH_LEFT", [&](const depth_image_t& m, const std::string&) {
    if (!frame) frame = m;
  });
  if (!bus.spinUntil([&] { return frame.has_value(); }, 10))
    return std::cerr << "fault_probe: no DEPTH_LEFT frame within 10 s\n", 1;
  frame->utime += static_cast<std::int64_t>(ahead_s * 1e6);
  const std::int64_t at = node::nowUtime();
  bus.publish("DEPTH_LEFT", *frame);
  std::cout << at << std::endl;
  return 0;
}

// ---------------------------------------------------------------- report
struct Log {
  std::vector<robot_state_t> states;
  std::vector<part_pose_t> poses;
  std::vector<sim_truth_t> truths;
  std::vector<nozzle_plan_t> plans;
  std::vector<heartbeat_t> heartbeats;
  std::vector<std::int64_t> heartbeat_rx;  ///< the logger's receive utime of each of `heartbeats`
  std::vector<launcher_status_t> launchers;
  std::vector<estop_t> estops;
  std::vector<point_cloud_t> clouds;
  std::int64_t undecodable = 0;  ///< garbage recorded by the logger
};

template <typename T>
bool decodeInto(const lcm::LogEvent* ev, std::vector<T>& out) {
  T m;
  try {  // garbage can make the generated decoder throw (a string length beyond the message)
    if (m.decode(ev->data, 0, ev->datalen) < 0) return false;
  } catch (const std::exception&) {
    return false;
  }
  out.push_back(std::move(m));
  return true;
}

Log readLog(const std::string& path) {
  lcm::LogFile file(path, "r");
  if (!file.good()) throw std::runtime_error("cannot read the LCM log " + path);
  Log log;
  for (const lcm::LogEvent* ev = file.readNextEvent(); ev; ev = file.readNextEvent()) {
    const std::string& c = ev->channel;
    bool ok = true;
    if (c == "ROBOT_STATE")
      ok = decodeInto(ev, log.states);
    else if (c == "PART_POSE")
      ok = decodeInto(ev, log.poses);
    else if (c == "SIM_TRUTH")
      ok = decodeInto(ev, log.truths);
    else if (c == "NOZZLE_PLAN")
      ok = decodeInto(ev, log.plans);
    else if (c == "HEARTBEAT") {
      ok = decodeInto(ev, log.heartbeats);
      if (ok) log.heartbeat_rx.push_back(ev->timestamp);
    } else if (c == "LAUNCHER")
      ok = decodeInto(ev, log.launchers);
    else if (c == "ESTOP")
      ok = decodeInto(ev, log.estops);
    else if (c == "POINTS")
      ok = decodeInto(ev, log.clouds);
    if (!ok) ++log.undecodable;
  }
  return log;
}

/// The log of a run whose host stepped its system clock by `step` us at `at` (wall clock before
/// the step): each stamp taken after the step is put back on the clock before it, so that times
/// across the step compare. A stamp more than half the step beyond `at` was taken after it.
void unstep(Log& log, std::int64_t at, std::int64_t step) {
  if (step == 0) return;
  auto fix = [&](std::int64_t& u) {
    if (u > 0 && (step < 0 ? u < at + step / 2 : u > at + step / 2)) u -= step;
  };
  for (robot_state_t& m : log.states) fix(m.utime), fix(m.plan_utime);
  for (part_pose_t& m : log.poses) fix(m.utime);
  for (sim_truth_t& m : log.truths) fix(m.utime);
  for (nozzle_plan_t& m : log.plans) fix(m.utime);
  for (heartbeat_t& m : log.heartbeats) fix(m.utime);
  for (std::int64_t& u : log.heartbeat_rx) fix(u);
  for (launcher_status_t& m : log.launchers) fix(m.utime);
  for (estop_t& m : log.estops) fix(m.utime);
  for (point_cloud_t& m : log.clouds) fix(m.utime);
}

Pose poseOf(const pose_t& m) {
  const std::optional<Pose> p = node::fromMsg(m);
  if (!p) throw std::runtime_error("a PART_POSE in the log has an invalid pose");
  return *p;
}

double maxAbsDiff(const double* a, const double* b) {
  double m = 0;
  for (int j = 0; j < 6; ++j) m = std::max(m, std::abs(a[j] - b[j]));
  return m;
}

/// The truth nearest in time to `utime` for `part`.
std::optional<Pose> truthAt(const Log& log, const std::string& part, std::int64_t utime) {
  const sim_truth_t* best = nullptr;
  for (const sim_truth_t& t : log.truths)
    if (!best || std::llabs(t.utime - utime) < std::llabs(best->utime - utime)) best = &t;
  if (!best || std::llabs(best->utime - utime) > 100000) return std::nullopt;
  for (const part_truth_t& p : best->parts)
    if (p.part == part) return node::fromMsg(p.T_cell_part);
  return std::nullopt;
}

struct Checker {
  int failed = 0;
  void measured(const std::string& what, double value, const char* unit) {
    std::printf("measured: %s = %.3f %s\n", what.c_str(), value, unit);
  }
  void check(bool ok, const std::string& what) {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
    failed += ok ? 0 : 1;
  }
};

/// The largest joint step between consecutive ROBOT_STATEs as a fraction of what qd_max allows
/// over that interval plus one 8 ms cycle of timing jitter; > 1 is a jump. Before the driver
/// first reaches the controller its q is unknown (zeros), so that stretch is left out.
double worstJointStep(const Log& log, const robot::ArmConfig& arm) {
  double worst = 0;
  bool connected = false;
  for (std::size_t i = 1; i < log.states.size(); ++i) {
    const robot_state_t &a = log.states[i - 1], &b = log.states[i];
    connected = connected || a.mode != robot_state_t::MODE_DISCONNECTED;
    if (!connected) continue;
    const double dt = (b.utime - a.utime) * 1e-6 + 0.008;
    for (int j = 0; j < 6; ++j) {
      const double r = std::abs(b.q[j] - a.q[j]) / (arm.qd_max[j] * dt);
      if (r > 1.0)
        std::printf("joint %d step %.4f rad in %.1f ms at utime %lld (modes %d -> %d: %s)\n", j + 1, b.q[j] - a.q[j],
                    (b.utime - a.utime) * 1e-3, static_cast<long long>(b.utime), a.mode, b.mode, b.mode_reason.c_str());
      worst = std::max(worst, r);
    }
  }
  return worst;
}

/// First utime >= from after which q stays within `tol` rad of its value until `until`.
std::optional<std::int64_t> atRestFrom(const Log& log, std::int64_t from, std::int64_t until, double tol = 1e-5) {
  std::optional<std::int64_t> rest;
  const robot_state_t* anchor = nullptr;
  for (const robot_state_t& s : log.states) {
    if (s.utime < from || s.utime > until) continue;
    if (!anchor || maxAbsDiff(anchor->q, s.q) > tol) anchor = &s, rest = s.utime;
  }
  return rest;
}

/// The most restarts the launchers reported for `process` ("": for any process).
int restartsOf(const Log& log, const std::string& process) {
  int restarts = 0;
  for (const launcher_status_t& l : log.launchers)
    for (const process_status_t& p : l.processes)
      if (process.empty() || p.name == process) restarts = std::max(restarts, static_cast<int>(p.restarts));
  return restarts;
}

/// Each process's heartbeat statistics, the largest value each took in the run.
std::map<std::string, std::map<std::string, double>> largestStats(const Log& log) {
  std::map<std::string, std::map<std::string, double>> stats;
  for (const heartbeat_t& h : log.heartbeats)
    for (std::size_t i = 0; i < h.stat_names.size(); ++i) {
      double& v = stats[h.process][h.stat_names[i]];
      v = std::max(v, h.stat_values[i]);
    }
  return stats;
}

/// The first ROBOT_STATE following a plan whose camera frame came after `after` and before
/// `before`: when the arm worked again on frames taken after a fault (0: never).
std::int64_t followingFramesAfter(const Log& log, std::int64_t after, std::int64_t before) {
  for (const robot_state_t& s : log.states)
    if (s.mode == robot_state_t::MODE_FOLLOWING && s.plan_utime > after && s.plan_utime < before) return s.utime;
  return 0;
}

/// POINTS stamped in (from, to].
int pointsIn(const Log& log, std::int64_t from, std::int64_t to) {
  return static_cast<int>(std::count_if(log.clouds.begin(), log.clouds.end(),
                                        [&](const point_cloud_t& p) { return p.utime > from && p.utime <= to; }));
}

/// POINTS per 10 s before `fault` (twice its last 5 s): the cell's own rate, 30 a second or a
/// sanitized build's third of it.
int usualPoints(Checker& c, const Log& log, std::int64_t fault) {
  const int usual = 2 * pointsIn(log, fault - 5000000, fault);
  c.measured("POINTS in 10 s before the fault (twice its last 5 s)", usual, "");
  return usual;
}

/// Checks that POINTS kept coming from 1 to 11 s after `t` at 80 % or more of `usual`.
void checkPointsKept(Checker& c, const Log& log, int usual, std::int64_t t, const std::string& after) {
  const int points = pointsIn(log, t + 1000000, t + 11000000);
  c.measured("POINTS from 1 to 11 s after" + after, points, "");
  c.check(usual > 0 && points >= 0.8 * usual,
          "POINTS kept coming after" + after + " (80 % of the rate before or more)");
}

int report(const std::string& fault, const std::string& log_path, const std::string& cell_path, std::int64_t at,
           std::int64_t until, std::int64_t step) {
  Log log = readLog(log_path);
  unstep(log, at, step);
  const robot::RobotSection robot = robot::readRobotSection(node::loadCell(cell_path));
  const robot::SafetyConfig& safety = robot.driver.safety;
  if (until == 0) until = std::numeric_limits<std::int64_t>::max();
  Checker c;
  std::printf("fault %s at utime %lld: %zu ROBOT_STATE, %zu PART_POSE, %zu NOZZLE_PLAN, %zu HEARTBEAT in the log\n",
              fault.c_str(), static_cast<long long>(at), log.states.size(), log.poses.size(), log.plans.size(),
              log.heartbeats.size());
  // No nozzle-part contact from the fault until 5 s after it ended (SIM_TRUTH's count).
  const std::int64_t window_end = (until == std::numeric_limits<std::int64_t>::max() ? at + 20000000 : until) + 5000000;
  std::int64_t contacts_before = -1, contacts_after = 0;
  for (const sim_truth_t& t : log.truths) {
    if (t.utime <= at) contacts_before = t.contact_count;
    if (t.utime <= window_end) contacts_after = t.contact_count;
  }
  if (contacts_before >= 0) {
    c.measured("nozzle-part contacts from the fault to 5 s after it", contacts_after - contacts_before, "");
    c.check(contacts_after == contacts_before, "no nozzle-part contact during the fault");
  }
  const double jump = worstJointStep(log, robot.driver.arm);
  c.measured("largest joint step / (qd_max x (dt + 8 ms))", jump, "");
  c.check(jump <= 1.0, "no joint jump anywhere in the run");

  if (fault == "tracker_killed") {
    // The tracker died at `at`; the launcher restarts it; it resumes from its state file.
    const part_pose_t *before = nullptr, *after = nullptr;
    for (const part_pose_t& p : log.poses) {
      if (p.utime <= at) before = &p;
      if (p.utime > at && p.status == part_pose_t::TRACKING && !after) after = &p;
    }
    c.check(before && after, "PART_POSE before the kill and TRACKING again after it");
    if (!before || !after) return 1;
    const double gap = (after->utime - before->utime) * 1e-6;
    c.measured("PART_POSE gap (kill, restart, resume)", gap, "s");
    const Pose P0 = poseOf(before->T_cell_part), P1 = poseOf(after->T_cell_part);
    c.measured("first pose after restart vs last before: rotation", rotationDistanceDeg(P0, P1), "deg");
    c.measured("first pose after restart vs last before: translation", translationDistance(P0, P1) * 1000, "mm");
    bool waited = false;
    for (const part_pose_t& p : log.poses)
      if (p.utime > at && p.utime < after->utime && p.status == part_pose_t::WAITING) waited = true;
    c.check(!waited, "the restarted tracker resumed (no WAITING pose from the initial pose)");
    // Resuming must not lose accuracy: the first pose after the restart is as close to the truth
    // as the last one before the kill (within 2 deg / 2 mm: one frame of tracking).
    const auto truth0 = truthAt(log, before->part, before->utime), truth1 = truthAt(log, after->part, after->utime);
    c.check(truth0 && truth1, "SIM_TRUTH at both poses");
    if (truth0 && truth1) {
      const double r0 = rotationDistanceDeg(*truth0, P0), r1 = rotationDistanceDeg(*truth1, P1);
      const double t0 = translationDistance(*truth0, P0) * 1000, t1 = translationDistance(*truth1, P1) * 1000;
      c.measured("error before the kill: rotation", r0, "deg");
      c.measured("error before the kill: translation", t0, "mm");
      c.measured("error after the restart: rotation", r1, "deg");
      c.measured("error after the restart: translation", t1, "mm");
      c.check(r1 <= r0 + 2 && t1 <= t0 + 2, "the restart lost no accuracy (within 2 deg / 2 mm of before)");
    }
    const int restarts = restartsOf(log, "tracker");
    c.measured("tracker restarts", restarts, "");
    c.check(restarts >= 1, "the launcher restarted the tracker");
    // The planner holds: no plan with waypoints from a frame older than stale_s + one frame is
    // executed while poses are missing; the arm comes to rest.
    std::int64_t hold_at = 0;
    for (const nozzle_plan_t& p : log.plans)
      if (p.utime > before->utime && p.num_waypoints == 0 && !hold_at) hold_at = p.utime;
    if (hold_at) c.measured("last PART_POSE -> planner's hold plan", (hold_at - before->utime) * 1e-6, "s");
    const auto rest = atRestFrom(log, at, after->utime);
    c.check(rest.has_value() && *rest < after->utime,
            "the arm came to rest while poses were missing (planner hold / driver stale-plan stop)");
    if (rest) c.measured("kill -> arm at rest", (*rest - at) * 1e-6, "s");
  } else if (fault == "link_cut") {
    // The robot host's link is down from `at` to `until`: no plans, no planner heartbeats.
    // The driver's deadlines run from the last planner heartbeat it received and the source frame
    // of the last plan it took, not from `at`: the cut takes effect when `ip link set down` has
    // run, which under load is tens of ms after `at`, and a heartbeat can still arrive meanwhile.
    // So the deadline is taken from the robot host's own log (its logger's receive time of the
    // last planner heartbeat; the newest plan_utime in the driver's ROBOT_STATE), and the driver
    // starts braking early enough to be at rest by then (+ one 8 ms cycle, ROBOT_STATE's
    // resolution, and 12 ms of slack).
    const auto rest = atRestFrom(log, at, until);
    c.check(rest.has_value(), "the arm came to rest during the cut");
    if (!rest) return 1;
    c.measured("cut -> arm at rest", (*rest - at) * 1e-6, "s");
    std::int64_t last_hb = 0, last_plan = 0;
    for (std::size_t i = 0; i < log.heartbeats.size(); ++i)
      if (log.heartbeats[i].process == "depowder-planner" && log.heartbeat_rx[i] < until)
        last_hb = std::max(last_hb, log.heartbeat_rx[i]);
    for (const robot_state_t& s : log.states)
      if (s.utime <= *rest) last_plan = std::max(last_plan, s.plan_utime);
    c.check(last_hb > 0 && last_plan > 0, "a planner heartbeat and a plan reached the robot host before the cut");
    if (last_hb == 0 || last_plan == 0) return 1;
    c.measured("cut -> last planner heartbeat received", (last_hb - at) * 1e-6, "s");
    c.measured("cut -> camera frame of the last plan", (last_plan - at) * 1e-6, "s");
    const std::int64_t due = std::min(last_plan + static_cast<std::int64_t>(safety.plan_max_age_s * 1e6),
                                      last_hb + static_cast<std::int64_t>(safety.planner_heartbeat_timeout_s * 1e6));
    constexpr double kSlackMs = 20;
    c.measured("arm at rest - first stop rule due", (*rest - due) * 1e-3, "ms");
    c.check((*rest - due) * 1e-3 <= kSlackMs,
            "at rest by the first stop rule due (+" + std::to_string(static_cast<int>(kSlackMs)) + " ms)");
    std::string reason;
    for (const robot_state_t& s : log.states)
      if (s.utime > at && s.utime < until && s.mode == robot_state_t::MODE_HOLDING) reason = s.mode_reason;
    std::printf("driver's reason: %s\n", reason.c_str());
    c.check(!reason.empty(), "the driver reported HOLDING during the cut");
    const robot_state_t* moved = nullptr;
    const robot_state_t* last_still = nullptr;
    for (const robot_state_t& s : log.states) {
      if (s.utime <= until)
        last_still = &s;
      else if (last_still && maxAbsDiff(last_still->q, s.q) > 1e-5 && !moved)
        moved = &s;
    }
    c.check(moved != nullptr, "the arm moved again after the link returned");
    if (!moved) return 1;
    c.measured("link back -> arm moving again", (moved->utime - until) * 1e-6, "s");
    // A plan sent during the cut is lost, not queued: the plan the arm moved on, as the driver's
    // own state names it (the robot host's logger may miss a NOZZLE_PLAN the driver got), was
    // made after the link returned. Its camera frame may be older by the pipeline's latency.
    constexpr double kLatency = 0.1;  // s: depth frame -> NOZZLE_PLAN, p99 about 30 ms
    c.measured("link back -> camera frame of the plan it moved on", (moved->plan_utime - until) * 1e-6, "s");
    c.check(moved->plan_id != last_still->plan_id && moved->plan_utime >= until - kLatency * 1e6,
            "it moved only on a plan made after the link returned (plan " + std::to_string(moved->plan_id) + ")");
  } else if (fault == "estop") {
    const estop_t* stop = nullptr;
    const estop_t* reset = nullptr;
    for (const estop_t& e : log.estops) {
      if (e.stop && !stop) stop = &e;
      if (!e.stop && stop && !reset) reset = &e;
    }
    c.check(stop && reset, "ESTOP stop and reset in the log");
    if (!stop || !reset) return 1;
    const robot_state_t* st = nullptr;
    for (const robot_state_t& s : log.states)
      if (s.utime <= stop->utime) st = &s;
    c.check(st && st->tool == waypoint_t::TOOL_VACUUM && st->mode == robot_state_t::MODE_FOLLOWING,
            "the arm was vacuuming when ESTOP came");
    const auto rest = atRestFrom(log, stop->utime, reset->utime);
    c.check(rest.has_value(), "the arm stayed at rest until the reset");
    if (!rest) return 1;
    // ROBOT_STATE comes every 8 ms: the stop is at most that much earlier than seen.
    const double stop_ms = (*rest - stop->utime) * 1e-3;
    c.measured("ESTOP -> arm at rest (ROBOT_STATE, 8 ms resolution)", stop_ms, "ms");
    c.check(stop_ms < 20, "stopped within 20 ms");
    bool estopped = true;
    for (const robot_state_t& s : log.states)
      if (s.utime > *rest && s.utime < reset->utime) estopped = estopped && s.mode == robot_state_t::MODE_ESTOPPED;
    c.check(estopped, "ESTOPPED until the reset");
    c.measured("held for", (reset->utime - *rest) * 1e-6, "s");
    std::int64_t moved = 0;
    for (const robot_state_t& s : log.states)
      if (s.utime > reset->utime && s.mode == robot_state_t::MODE_FOLLOWING && !moved) moved = s.utime;
    c.check(moved > 0, "work resumed after the reset");
    if (moved) c.measured("reset -> following a plan again", (moved - reset->utime) * 1e-6, "s");
  } else if (fault == "garbage") {
    std::map<std::string, std::int64_t> errors;
    for (const heartbeat_t& h : log.heartbeats) errors[h.process] = std::max(errors[h.process], h.decode_errors);
    for (const auto& [process, n] : errors)
      std::printf("decode errors counted by %s: %lld\n", process.c_str(), (long long)n);
    for (const char* p :
         {"depowder-tracker", "depowder-progress", "depowder-planner", "depowder-driver", "depowder-camera"})
      c.check(errors[p] > 0, std::string(p) + " counted the garbage in its heartbeat");
    const int restarts = restartsOf(log, "");
    c.measured("restarts of any process", restarts, "");
    c.check(restarts == 0, "no process died");
    c.measured("undecodable messages recorded by the logger", static_cast<double>(log.undecodable), "");
  } else if (fault == "camera_silent") {
    int frames = 0, one_camera = 0, good = 0, poses = 0;
    double worst_rot = 0, worst_trans = 0, longest_lost = 0;
    std::int64_t lost_since = 0, worst_rot_at = at, worst_trans_at = at;
    // Half a second off either end: the fault's utime is the wall time the sim applied it, and a
    // sim catching up after a stall ends the 20 s of sim time a little early in wall time.
    for (const point_cloud_t& p : log.clouds)
      if (p.utime > at + 500000 && p.utime < until - 500000) ++frames, one_camera += p.num_sources == 1;
    for (const part_pose_t& p : log.poses) {
      if (p.utime <= at + 500000 || p.utime >= until) continue;
      ++poses;
      const bool gave = p.status == part_pose_t::TRACKING || p.status == part_pose_t::DEGRADED;
      if (gave)
        ++good, lost_since = 0;
      else if (!lost_since)
        lost_since = p.utime;
      if (lost_since) longest_lost = std::max(longest_lost, (p.utime - lost_since) * 1e-6);
      if (const auto truth = truthAt(log, p.part, p.utime)) {
        if (const double r = rotationDistanceDeg(*truth, poseOf(p.T_cell_part)); r > worst_rot)
          worst_rot = r, worst_rot_at = p.utime;
        if (const double t = translationDistance(*truth, poseOf(p.T_cell_part)); t > worst_trans)
          worst_trans = t, worst_trans_at = p.utime;
      }
    }
    c.measured("POINTS while one camera was silent", frames, "");
    c.measured("of them from one camera", one_camera, "");
    c.check(frames > 0 && one_camera == frames, "POINTS kept coming, from the other camera");
    // With one camera the nozzle can hide most of the part: those frames are LOST (last pose
    // kept) until it moves on; the part must never be lost for longer.
    c.measured("PART_POSE tracking or degraded while silent", poses ? 100.0 * good / poses : 0, "%");
    c.measured("longest stretch of LOST frames", longest_lost, "s");
    c.check(poses > 0 && good > 0 && longest_lost < 3.0, "tracking continued (never LOST for 3 s or more)");
    c.measured("worst pose error while silent: rotation", worst_rot, "deg");
    c.measured("worst pose error while silent: translation", worst_trans * 1000, "mm");
    c.measured("  worst rotation at (from the silence)", (worst_rot_at - at) * 1e-6, "s");
    c.measured("  worst translation at", (worst_trans_at - at) * 1e-6, "s");
    c.check(worst_rot < 15 && worst_trans < 0.015,
            "within 15 deg / 15 mm of the truth (the paper's Table II criterion)");
    std::string said;
    for (const heartbeat_t& h : log.heartbeats)
      if (h.process == "depowder-camera" && h.utime > at && h.utime < until && h.state == heartbeat_t::DEGRADED)
        said = h.state_reason;
    std::printf("camera proxy said: %s\n", said.c_str());
    c.check(said.find("silent") != std::string::npos, "the camera proxy reported the silent camera");
    std::string tracker_said;
    for (const heartbeat_t& h : log.heartbeats)
      if (h.process == "depowder-tracker" && h.utime > at && h.utime < until &&
          h.state_reason.find(" only") != std::string::npos)
        tracker_said = h.state_reason;
    std::printf("tracker said: %s\n", tracker_said.c_str());
    c.check(!tracker_said.empty(), "the tracker reported tracking on the remaining camera");
  } else if (fault == "clock_jump") {
    // One frame a year ahead: the camera proxy refuses it as a bad stamp (the camera's next frame
    // does not confirm a clock jumped forward), so nothing downstream sees it or starts over.
    constexpr std::int64_t kDay = 86400LL * 1000000;
    const int ahead = pointsIn(log, at + kDay, std::numeric_limits<std::int64_t>::max());
    c.measured("POINTS stamped a day or more ahead", ahead, "");
    c.check(ahead == 0, "no time step from the future went out");
    checkPointsKept(c, log, usualPoints(c, log, at), at, " it");
    auto stats = largestStats(log);
    c.measured("depowder-camera frames refused as far ahead", stats["depowder-camera"]["dropped_ahead"], "");
    c.check(stats["depowder-camera"]["dropped_ahead"] == 1, "the camera proxy refused the frame and counted it");
    for (const char* p : {"depowder-camera", "depowder-planner"}) {
      c.measured(std::string(p) + " clock restarts", stats[p]["clock_restarts"], "");
      c.check(stats[p]["clock_restarts"] == 0, std::string(p) + " did not start its clock over");
    }
    bool followed_future = false;
    for (const robot_state_t& s : log.states) followed_future = followed_future || s.plan_utime > at + kDay;
    c.check(!followed_future, "the driver followed no plan stamped in the future");
    const std::int64_t resumed = followingFramesAfter(log, at, at + kDay);
    if (resumed) c.measured("fault -> following a plan from a later frame", (resumed - at) * 1e-6, "s");
    c.check(resumed && resumed - at < 5000000, "the arm followed plans from later frames within 5 s");
  } else if (fault == "clock_step") {
    // Every process of the host saw its system clock step back at `at` and forward again, to
    // the right time, at `until` (the times here are put back on the clock before the steps).
    // Back: the driver stops the plan whose frame is now ahead of its clock, and the camera proxy
    // and the planner start their time over on the second frame and input of the new clock.
    // Forward: the driver stops the plan now that old, and the camera proxy refuses a camera's
    // first frame as far ahead and takes its second, which confirms it (one camera's confirmed
    // jump moves the newest time on: the other's first frame may then be taken). Neither loses
    // the arm for long, and no heartbeat, timed on the steady clock, falls silent.
    if (until == std::numeric_limits<std::int64_t>::max()) return usage();
    struct Step {
      std::int64_t at;
      const char* name;
      const char* reason;  ///< in the driver's reason for the stop it makes
      const char* made;
      std::int64_t next;  ///< the next step (frames after it are not this one's)
    };
    const int usual_points = usualPoints(c, log, at);
    for (const Step& st :
         {Step{at, "back", "ahead of this host's clock", "ahead of its clock", until},
          Step{until, "forward", " s old (limit", "stale", std::numeric_limits<std::int64_t>::max()}}) {
      const std::string after = std::string(" the step ") + st.name;
      checkPointsKept(c, log, usual_points, st.at, after);
      const robot_state_t* held = nullptr;
      for (const robot_state_t& s : log.states)
        if (!held && s.utime >= st.at && s.mode == robot_state_t::MODE_HOLDING) held = &s;
      std::printf("driver's reason after%s: %s\n", after.c_str(), held ? held->mode_reason.c_str() : "");
      c.check(held && held->mode_reason.find(st.reason) != std::string::npos,
              "the driver stopped the plan that" + after + " made " + st.made);
      if (held) c.measured(after.substr(1) + " -> driver holding", (held->utime - st.at) * 1e-6, "s");
      const std::int64_t resumed = followingFramesAfter(log, st.at, st.next);
      if (resumed)
        c.measured(after.substr(1) + " -> following a plan from a frame after it", (resumed - st.at) * 1e-6, "s");
      c.check(resumed && resumed - st.at < 5000000, "the arm followed plans from frames after" + after + " within 5 s");
    }
    // The logger's clock stepped too, and its event times with it: the heartbeats' uptime_s tell
    // both steps and nothing else, and the log mended of them has no gap a replay would wait out.
    const node::LogTimes times = node::mendLogTimes(log_path);
    for (const node::LogGap& g : times.gaps) std::printf("log: %s\n", times.describe(g).c_str());
    c.check(times.gaps.size() == 2 && times.steps() == 2, "the log's event times hold the two steps, and no other gap");
    for (std::size_t k = 0; k < 2 && k < times.gaps.size(); ++k) {
      const node::LogGap& g = times.gaps[k];
      const double found = (g.recorded_us - g.mended_us) * 1e-6, expected = (k == 0 ? step : -step) * 1e-6;
      const std::int64_t where = times.utime[g.event] - (k == 0 ? at : until);
      c.measured(std::string("step ") + (k == 0 ? "back" : "forward") + " found in the log's event times", found, "s");
      c.check(
          std::abs(found - expected) < 0.1 && where > -500000 && where < 1000000,
          std::string("the log's step ") + (k == 0 ? "back" : "forward") + " was found to 0.1 s, where it was made");
    }
    std::int64_t widest = 0;
    for (std::size_t i = 1; i < times.utime.size(); ++i) widest = std::max(widest, times.utime[i] - times.utime[i - 1]);
    c.measured("widest gap of the mended log's event times", widest * 1e-6, "s");
    c.check(widest < 1000000, "the mended log has no gap of 1 s");
    auto stats = largestStats(log);
    const double refused = stats["depowder-camera"]["dropped_ahead"];
    c.measured("depowder-camera frames refused as far ahead", refused, "");
    c.check(refused >= 1 && refused <= 2,
            "the camera proxy refused a frame of each camera at most, at the step forward");
    for (const char* p : {"depowder-camera", "depowder-planner"}) {
      c.measured(std::string(p) + " clock restarts", stats[p]["clock_restarts"], "");
      c.check(stats[p]["clock_restarts"] == 1, std::string(p) + " started its time over once, at the step back");
    }
    // The longest silence of each process's heartbeat (every 0.5 s) from 5 s before the first
    // step to 20 s after the second, counting the silence to the end of that window.
    const std::int64_t from = at - 5000000, to = until + 20000000;
    std::map<std::string, std::int64_t> last, longest;
    for (const heartbeat_t& h : log.heartbeats) {
      if (h.utime < from || h.utime > to) continue;
      if (last.count(h.process)) longest[h.process] = std::max(longest[h.process], h.utime - last[h.process]);
      last[h.process] = h.utime;
    }
    for (const char* p :
         {"depowder-camera", "depowder-tracker", "depowder-progress", "depowder-planner", "depowder-driver"}) {
      if (last.count(p)) longest[p] = std::max(longest[p], to - last[p]);
      c.measured(std::string(p) + "'s longest heartbeat silence around the steps", longest[p] * 1e-6, "s");
      c.check(last.count(p) && longest[p] < 2000000, std::string(p) + "'s heartbeat never fell silent for 2 s");
    }
    const int restarts = restartsOf(log, "");
    c.measured("restarts of any process", restarts, "");
    c.check(restarts == 0, "no process died");
  } else if (fault == "controller_drop") {
    // Reported: a DISCONNECTED ROBOT_STATE (ROBOT_STATE comes every 8 ms: a reconnect faster than
    // that shows only in the heartbeat's counter), then the reconnect counted in the heartbeat.
    std::int64_t disconnected = 0, reconnected = 0, following = 0;
    std::string why;
    for (const robot_state_t& s : log.states)
      if (s.utime >= at && s.mode == robot_state_t::MODE_DISCONNECTED && !disconnected)
        disconnected = s.utime, why = s.mode_reason;
    double reconnects_before = 0, reconnects = 0;
    for (const heartbeat_t& h : log.heartbeats)
      if (h.process == "depowder-driver")
        for (int i = 0; i < h.num_stats; ++i)
          if (h.stat_names[i] == "reconnects") {
            if (h.utime < at) reconnects_before = h.stat_values[i];
            if (h.utime >= at && h.stat_values[i] > reconnects_before && !reconnected) reconnected = h.utime;
            reconnects = std::max(reconnects, h.stat_values[i]);
          }
    for (const robot_state_t& s : log.states)
      if (reconnected && s.utime >= std::max(disconnected, at) && s.mode == robot_state_t::MODE_FOLLOWING && !following)
        following = s.utime;
    if (disconnected) std::printf("driver's reason: %s\n", why.c_str());
    if (disconnected) c.measured("drop -> DISCONNECTED in ROBOT_STATE", (disconnected - at) * 1e-3, "ms");
    c.measured("driver reconnects", reconnects - reconnects_before, "");
    c.check(reconnected > 0, "the driver reconnected and counted it in its heartbeat");
    if (reconnected) c.measured("drop -> heartbeat with the reconnect (2 Hz)", (reconnected - at) * 1e-6, "s");
    c.check(following > 0, "the driver re-took the arm and follows a plan again");
  } else {
    return usage();
  }
  std::printf("%d checks failed\n", c.failed);
  return c.failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string cmd = argv[1];
  std::map<std::string, std::string> opt;
  std::vector<std::string> pos;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) == 0) {
      if (i + 1 >= argc) return usage();
      opt[a] = argv[++i];
    } else {
      pos.push_back(a);
    }
  }
  auto num = [&](const std::string& k, double d) { return opt.count(k) ? std::stod(opt[k]) : d; };
  try {
    if (cmd == "wait" && pos.size() == 1) return waitFor(pos[0], num("--timeout", 300));
    if (cmd == "garbage")
      return garbage(num("--seconds", 20), num("--rate", 5), static_cast<unsigned>(num("--seed", 1)));
    if (cmd == "future") return future(num("--ahead", 365 * 86400.0));
    if (cmd == "report" && pos.size() == 2 && opt.count("--cell") && opt.count("--at"))
      return report(pos[0], pos[1], opt["--cell"], std::stoll(opt["--at"]),
                    opt.count("--until") ? std::stoll(opt["--until"]) : 0,
                    static_cast<std::int64_t>(num("--step", 0) * 1e6));
  } catch (const std::exception& e) {
    std::cerr << "fault_probe: " << e.what() << std::endl;
    return 1;
  }
  return usage();
}
