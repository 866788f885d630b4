// depowder-logmend: takes the steps of the recording host's clock out of an LCM log's event
// times, so that lcm-logplayer replays it at the pace it was recorded (log_time.hpp). Channels,
// messages and their stamps stay as recorded: processes fed the replay meet the steps of their
// sources' clocks as the live cell did. ROBOT_STATE recorded before robot_state_t gained
// `measured` is written again in the present type, the one change to a message. A damaged log
// (log_reader.hpp) is mended into a whole one: every whole event, the damaged stretches named.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/node/log_time.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/robot_state_v1_t.hpp"

using namespace depowder;

namespace {

/// ROBOT_STATE recorded before `measured` (lcmtypes/legacy/robot_state_v1_t.lcm) in the present
/// robot_state_t. `measured` is the driver's rule as the modes tell it: the arm has been read in
/// IDLE, FOLLOWING and HOLDING, not while DISCONNECTED; FAULT and ESTOPPED keep what the message
/// before on the channel said (a controller error or an ESTOP with the connection up keeps the
/// arm's joints; one before the first read, or after the link was lost, has none).
class RobotStateUpgrade {
 public:
  /// Points `e` at the upgraded message when it holds a robot_state_v1_t; else leaves it.
  void apply(lcm::LogEvent& e) {
    robot_state_v1_t old;
    if (old.decode(e.data, 0, e.datalen) < 0) return;  // another type, or not decodable: as recorded
    robot_state_t now;
    now.utime = old.utime;
    now.mode = old.mode;
    now.mode_reason = old.mode_reason;
    bool& measured = measured_[e.channel];
    switch (old.mode) {
      case robot_state_t::MODE_IDLE:
      case robot_state_t::MODE_FOLLOWING:
      case robot_state_t::MODE_HOLDING:
        measured = true;
        break;
      case robot_state_t::MODE_FAULT:
      case robot_state_t::MODE_ESTOPPED:
        break;
      default:
        measured = false;
    }
    now.measured = measured;
    std::copy(std::begin(old.q), std::end(old.q), now.q);
    std::copy(std::begin(old.qd), std::end(old.qd), now.qd);
    now.T_cell_nozzle = old.T_cell_nozzle;
    now.tool = old.tool;
    now.plan_id = old.plan_id;
    now.waypoint_index = old.waypoint_index;
    now.plan_utime = old.plan_utime;
    bytes_.resize(static_cast<std::size_t>(now.getEncodedSize()));
    now.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
    e.data = bytes_.data();
    e.datalen = static_cast<std::int32_t>(bytes_.size());
    ++upgraded_;
    measured_count_ += measured;
  }
  std::size_t upgraded() const { return upgraded_; }
  std::size_t measured() const { return measured_count_; }

 private:
  std::map<std::string, bool> measured_;  ///< per channel: several cells' drivers in one log
  std::vector<std::uint8_t> bytes_;
  std::size_t upgraded_ = 0, measured_count_ = 0;
};

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-logmend: " << error << "\n";
  std::cerr << "usage: depowder-logmend RUN.lcmlog [MENDED.lcmlog] [--prefix P]\n"
               "  Prints each gap of RUN's event times beyond the ordinary: the time going back more\n"
               "  than 0.25 s, or no event for more than 1 s. A process's heartbeats across a gap (their\n"
               "  uptime_s, on the steady clock) tell a step of the recording host's clock from a silence;\n"
               "  with none, a step back counts no time and a long gap is kept. With MENDED, writes the log\n"
               "  again with each step taken out of its event times (channels, messages and their stamps\n"
               "  unchanged), for lcm-logplayer. ROBOT_STATE recorded before robot_state_t gained\n"
               "  `measured` is written as robot_state_t, `measured` told by its modes. Bytes that are not\n"
               "  a whole event (a recording cut short, a damaged disk) are named and left out; MENDED\n"
               "  holds every whole event (lcm-logplayer stops at the first damaged header). --prefix: the\n"
               "  cell's channel prefix (its heartbeats on PHEARTBEAT).\n"
               "  Exit 0 when done, 2 when a log cannot be read or written, or RUN is not an LCM log.\n";
  return error.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string in, out, prefix;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help") return usage();
    if (a == "--prefix") {
      if (i + 1 >= argc) return usage("missing value after --prefix");
      prefix = argv[++i];
    } else if (!a.empty() && a[0] == '-') {
      return usage("unknown option " + a);
    } else if (in.empty()) {
      in = a;
    } else if (out.empty()) {
      out = a;
    } else {
      return usage("one log in and one out, got '" + a + "' too");
    }
  }
  if (in.empty()) return usage("missing RUN.lcmlog");
  try {
    std::error_code ec;
    if (!out.empty() && std::filesystem::equivalent(in, out, ec))
      return usage("MENDED must be another file than RUN: the recording is kept as it is");
    const node::LogTimes times = node::mendLogTimes(in, prefix + "HEARTBEAT");
    if (times.utime.empty() && !times.damage.empty())
      throw std::runtime_error("'" + in + "' is not an LCM log: none of its " + std::to_string(times.damage[0].bytes) +
                               " bytes is an event");
    for (const node::LogGap& gap : times.gaps) std::cout << times.describe(gap) << "\n";
    for (const node::LogDamage& d : times.damage) std::cout << node::describe(d) << "\n";
    std::cout << times.utime.size() << " events, " << times.steps() << (times.steps() == 1 ? " step" : " steps")
              << " of the clock taken out";
    if (!times.damage.empty())
      std::cout << ", " << times.damage.size() << (times.damage.size() == 1 ? " damaged stretch" : " damaged stretches")
                << (out.empty() ? "" : " left out (every whole event is written)");
    std::cout << "\n";

    node::LogReader from(in);
    std::unique_ptr<lcm::LogFile> to;
    if (!out.empty()) to = std::make_unique<lcm::LogFile>(out, "w");
    if (to && !to->good()) throw std::runtime_error("cannot write LCM log '" + out + "'");
    RobotStateUpgrade upgrade;
    std::size_t k = 0;
    for (const lcm::LogEvent* e; k < times.utime.size() && (e = from.next()) != nullptr; ++k) {
      lcm::LogEvent mended = *e;
      mended.timestamp = times.utime[k];
      upgrade.apply(mended);
      if (to && to->writeEvent(&mended) != 0) throw std::runtime_error("cannot write LCM log '" + out + "'");
    }
    if (k < times.utime.size()) throw std::runtime_error("'" + in + "' changed while it was read");
    if (upgrade.upgraded() > 0)
      std::cout << upgrade.upgraded() << " ROBOT_STATE recorded before robot_state_t gained `measured`"
                << (to ? " written as robot_state_t, " : ", ") << upgrade.measured() << " of them measured\n";
    if (to && from.next() != nullptr)
      std::cerr << "depowder-logmend: '" << in << "' grew while it was read: its first " << k
                << " events are written\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "depowder-logmend: " << e.what() << "\n";
    return 2;
  }
}
