// depowder-logmend: takes the steps of the recording host's clock out of an LCM log's event
// times, so that lcm-logplayer replays it at the pace it was recorded (log_time.hpp). Channels,
// messages and their stamps stay as recorded: processes fed the replay meet the steps of their
// sources' clocks as the live cell did.
#include <filesystem>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "depowder/node/log_time.hpp"

using namespace depowder;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-logmend: " << error << "\n";
  std::cerr << "usage: depowder-logmend RUN.lcmlog [MENDED.lcmlog] [--prefix P]\n"
               "  Prints each gap of RUN's event times beyond the ordinary: the time going back more\n"
               "  than 0.25 s, or no event for more than 1 s. A process's heartbeats across a gap (their\n"
               "  uptime_s, on the steady clock) tell a step of the recording host's clock from a silence;\n"
               "  with none, a step back counts no time and a long gap is kept. With MENDED, writes the log\n"
               "  again with each step taken out of its event times (channels, messages and their stamps\n"
               "  unchanged), for lcm-logplayer. --prefix: the cell's channel prefix (its heartbeats on\n"
               "  PHEARTBEAT).\n"
               "  Exit 0 when done, 2 when a log cannot be read or written.\n";
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
    for (const node::LogGap& gap : times.gaps) std::cout << times.describe(gap) << "\n";
    std::cout << times.utime.size() << " events, " << times.steps() << " steps of the clock taken out\n";
    if (out.empty()) return 0;

    lcm::LogFile from(in, "r"), to(out, "w");
    if (!to.good()) throw std::runtime_error("cannot write LCM log '" + out + "'");
    std::size_t k = 0;
    for (const lcm::LogEvent* e; k < times.utime.size() && (e = from.readNextEvent()) != nullptr; ++k) {
      lcm::LogEvent mended = *e;
      mended.timestamp = times.utime[k];
      if (to.writeEvent(&mended) != 0) throw std::runtime_error("cannot write LCM log '" + out + "'");
    }
    if (k < times.utime.size()) throw std::runtime_error("'" + in + "' changed while it was read");
    if (from.readNextEvent() != nullptr)
      std::cerr << "depowder-logmend: '" << in << "' grew while it was read: its first " << k
                << " events are written\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "depowder-logmend: " << e.what() << "\n";
    return 2;
  }
}
