#include "depowder/node/args.hpp"

#include <iostream>

#include "depowder/node/cell.hpp"

namespace depowder::node {

std::optional<NodeArgs> parseNodeArgs(int argc, char** argv, const std::string& process, const std::string& usage,
                                      int* exit_code) {
  auto stop = [&](const std::string& error) -> std::optional<NodeArgs> {
    if (!error.empty()) std::cerr << process << ": " << error << "\n";
    std::cerr << usage;
    *exit_code = error.empty() ? 0 : 2;
    return std::nullopt;
  };
  NodeArgs args;
  args.cell = defaultCellPath();
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return stop("");
    if (a != "--cell" && a != "--url" && a != "--prefix") return stop("unknown option " + a);
    if (i + 1 >= argc) return stop("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--cell") args.cell = v;
    if (a == "--url") args.url = v;
    if (a == "--prefix") args.prefix = v;
  }
  return args;
}

}  // namespace depowder::node
