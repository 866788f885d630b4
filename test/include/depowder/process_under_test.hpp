// A depowder process started by a test (the LCM process tests, run inside a private network
// namespace): a temporary directory of its own for the files it reads, a channel prefix of its
// own, stopped by SIGTERM (at the end of the test, killed if it will not stop) and reaped.
//
//   testutil::ProcessUnderTest tracker("depowder-tracker");
//   tracker.start({"--config", tracker.write("cell.yaml", yaml), "--url", url, "--prefix", tracker.prefix()});
//   ...
//   EXPECT_EQ(tracker.terminate(), 0);  // a clean exit
// A tool that runs to its end: `int status = logcheck.run({"compare", ...}, &printed);`.
#pragma once

#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/child_process.hpp"

namespace depowder::testutil {

class ProcessUnderTest {
 public:
  /// `name`: the executable in the build's bin directory, e.g. "depowder-tracker".
  explicit ProcessUnderTest(std::string name) : name_(std::move(name)) {
    std::string short_name = name_.substr(name_.find('-') + 1);  // "tracker"
    std::string dir = "/tmp/depowder_" + short_name + "_test_XXXXXX";
    if (mkdtemp(dir.data()) == nullptr) throw std::runtime_error("cannot create a temporary directory for " + name_);
    dir_ = dir;
    for (char& c : short_name) c = c == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    prefix_ = short_name + "_TEST_" + std::to_string(getpid()) + "_";
  }
  ProcessUnderTest(const ProcessUnderTest&) = delete;
  ProcessUnderTest& operator=(const ProcessUnderTest&) = delete;
  ~ProcessUnderTest() {
    child_.reset();
    std::system(("rm -rf '" + dir_ + "'").c_str());
  }

  std::string exe() const { return std::string(DEPOWDER_BIN_DIR) + "/" + name_; }
  const std::string& dir() const { return dir_; }
  /// The channel prefix to pass with --prefix, so parallel tests never hear each other.
  const std::string& prefix() const { return prefix_; }

  /// Writes `text` to `file` in the directory; returns its path.
  std::string write(const std::string& file, const std::string& text) const {
    const std::string path = dir_ + "/" + file;
    std::ofstream(path) << text;
    return path;
  }

  /// Starts the executable with `args`, and `env` ("NAME=value", through env(1)) if any.
  void start(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
    if (child_) throw std::logic_error(name_ + " is already running");
    std::vector<std::string> argv;
    if (!env.empty()) {
      argv.push_back("env");
      argv.insert(argv.end(), env.begin(), env.end());
    }
    argv.push_back(exe());
    argv.insert(argv.end(), args.begin(), args.end());
    child_ = std::make_unique<ChildProcess>(argv);
  }

  /// Runs the executable with `args` to its end, for a tool: its exit code (-1 if it did not
  /// exit within `timeout_s`), and what it printed on stdout and stderr in `out`.
  int run(const std::vector<std::string>& args, std::string* out, double timeout_s = 60) const {
    std::vector<std::string> argv{exe()};
    argv.insert(argv.end(), args.begin(), args.end());
    const std::string log = dir_ + "/run.out";
    const int status = ChildProcess(argv, log).wait(timeout_s);
    std::stringstream text;
    text << std::ifstream(log).rdbuf();
    *out = text.str();
    return status;
  }

  /// SIGTERM, then its exit code (128 + the signal if one ended it); -1 if it was not running
  /// or did not exit within 30 s.
  int terminate() {
    if (!child_) return -1;
    const int status = child_->stop(30.0);
    child_.reset();
    return status;
  }

 private:
  std::string name_, dir_, prefix_;
  std::unique_ptr<ChildProcess> child_;
};

}  // namespace depowder::testutil
