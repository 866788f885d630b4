// depowder-estop: publish an emergency stop (or its reset) on ESTOP.
#include <chrono>
#include <cstring>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "depowder/estop_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"

namespace {
int usage(const char* error = nullptr) {
  if (error) std::cerr << "depowder-estop: " << error << "\n";
  std::cerr << "usage: depowder-estop stop|reset [--reason TEXT] [--repeat N] [--cell FILE] [--url URL] [--prefix P]\n"
               "  stop   the driver halts the arm at once and ignores plans until a reset\n"
               "  reset  clears a previous stop (the driver re-validates before moving)\n"
               "  The message is sent N times (default 3, 5 ms apart) since UDP may drop one, on the\n"
               "  bus of the cell file's lcm section (default: the default cell) unless --url / --prefix.\n"
               "  Exits 1 if a send failed.\n";
  return error ? 2 : 0;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage("missing stop|reset");
  if (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) return usage();
  const std::string action = argv[1];
  if (action != "stop" && action != "reset") return usage(("unknown action '" + action + "'").c_str());
  std::string reason = "operator", cell;
  std::optional<std::string> url, prefix;
  int repeat = 3;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage(("missing value after " + a).c_str());
    if (a == "--reason")
      reason = argv[++i];
    else if (a == "--repeat")
      repeat = std::max(1, std::atoi(argv[++i]));
    else if (a == "--cell")
      cell = argv[++i];
    else if (a == "--url")
      url = argv[++i];
    else if (a == "--prefix")
      prefix = argv[++i];
    else
      return usage(("unknown option " + a).c_str());
  }
  try {
    const depowder::node::LcmConfig lcm = depowder::node::toolBus("depowder-estop", cell, url, prefix);
    depowder::node::Bus bus(lcm.url, lcm.prefix);
    depowder::node::Heartbeat heartbeat(bus, "depowder-estop");
    depowder::estop_t msg{};
    msg.source = "depowder-estop@" + depowder::node::hostName();
    msg.stop = action == "stop";
    msg.reason = reason;
    for (int k = 0; k < repeat; ++k) {
      msg.utime = depowder::node::nowUtime();
      bus.publish("ESTOP", msg);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const std::vector<std::string> errors = bus.takeErrors();
    if (!errors.empty()) {
      for (const std::string& e : errors) std::cerr << "depowder-estop: " << e << "\n";
      std::cerr << "depowder-estop: ESTOP " << action << " NOT sent on " << bus.channel("ESTOP") << "\n";
      return 1;
    }
    heartbeat.setState(depowder::heartbeat_t::RUNNING, action);
    heartbeat.publish();
    std::cout << "ESTOP " << action << " sent " << repeat << "x on " << bus.channel("ESTOP") << "\n";
  } catch (const std::exception& e) {
    std::cerr << "depowder-estop: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
