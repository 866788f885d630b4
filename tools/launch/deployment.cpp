#include "deployment.hpp"

#include <set>
#include <stdexcept>

#include "depowder/node/yaml.hpp"

namespace depowder::launch {

namespace {
ProcessSpec readProcess(const node::YamlReader& r) {
  ProcessSpec p;
  r.require("name", p.name);
  r.require("command", p.command);
  r.read("args", p.args);
  std::string restart = "on-failure";
  r.readChoice("restart", restart, {"never", "on-failure", "always"});
  p.restart = restart == "never" ? Restart::kNever : restart == "always" ? Restart::kAlways : Restart::kOnFailure;
  r.read("max_restarts", p.max_restarts, 0, 1000);
  r.read("start_delay_s", p.start_delay_s, 0.0, 60.0);
  r.read("ends_run", p.ends_run);
  r.read("realtime", p.realtime, 0, 99);
  r.finish();
  return p;
}
}  // namespace

Deployment loadDeployment(const std::string& path) {
  const node::YamlReader root = node::YamlReader::loadFile(path);
  Deployment d;
  d.file = path;
  root.read("lcm_url", d.lcm_url);
  root.read("variables", d.variables);
  std::set<std::string> hosts;
  for (const node::YamlReader& h : root.items("hosts")) {
    HostSpec host;
    h.require("name", host.name);
    if (!hosts.insert(host.name).second) h.fail("name", "is used twice");
    std::set<std::string> names;
    for (const node::YamlReader& p : h.items("processes")) {
      host.processes.push_back(readProcess(p));
      if (!names.insert(host.processes.back().name).second) p.fail("name", "is used twice on this host");
    }
    if (host.processes.empty()) h.fail("processes", "must list at least one process");
    h.finish();
    d.hosts.push_back(host);
  }
  if (d.hosts.empty()) root.fail("hosts", "must list at least one host");
  root.finish();
  return d;
}

std::string expand(const std::string& text, const std::map<std::string, std::string>& vars) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    if (text.compare(i, 2, "${") == 0) {
      const auto end = text.find('}', i);
      if (end == std::string::npos) throw std::invalid_argument("unterminated ${ in '" + text + "'");
      const std::string name = text.substr(i + 2, end - i - 2);
      const auto it = vars.find(name);
      if (it == vars.end()) throw std::invalid_argument("unknown variable ${" + name + "} in '" + text + "'");
      out += it->second;
      i = end + 1;
    } else {
      out += text[i++];
    }
  }
  return out;
}

}  // namespace depowder::launch
