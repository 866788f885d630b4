// The command line every cell process shares: --cell FILE, --url URL, --prefix P, --help.
#pragma once

#include <optional>
#include <string>

namespace depowder::node {

struct NodeArgs {
  std::string cell;                   ///< cell YAML (default: defaultCellPath())
  std::optional<std::string> url;     ///< overrides lcm.url
  std::optional<std::string> prefix;  ///< overrides lcm.prefix
};

/// Parses the shared flags. When the process should exit instead (--help: 0; an unknown
/// option or a missing value: 2, after "PROCESS: what was wrong"), prints `usage` to stderr,
/// sets *exit_code and returns nullopt.
std::optional<NodeArgs> parseNodeArgs(int argc, char** argv, const std::string& process, const std::string& usage,
                                      int* exit_code);

}  // namespace depowder::node
