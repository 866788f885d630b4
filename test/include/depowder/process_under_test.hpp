// A depowder process started by a test (the LCM process tests, run inside a private network
// namespace): a temporary directory of its own for the files it reads, a channel prefix of its
// own, stopped by SIGTERM or, at the end of the test, killed and reaped.
//
//   testutil::ProcessUnderTest tracker("depowder-tracker");
//   tracker.start({"--config", tracker.write("cell.yaml", yaml), "--url", url, "--prefix", tracker.prefix()});
//   ...
//   EXPECT_EQ(tracker.terminate(), 0);  // a clean exit
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

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
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
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

  /// Starts the executable with `args`.
  void start(const std::vector<std::string>& args) {
    if (pid_ > 0) throw std::logic_error(name_ + " is already running");
    std::vector<char*> argv{const_cast<char*>(name_.c_str())};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const std::string path = exe();
    pid_ = fork();
    if (pid_ == 0) {
      execv(path.c_str(), argv.data());
      _exit(127);
    }
    if (pid_ < 0) throw std::runtime_error("cannot fork " + name_);
  }

  /// SIGTERM, then its exit code; -1 if it was not running or did not exit by itself (a signal).
  int terminate() {
    if (pid_ <= 0) return -1;
    kill(pid_, SIGTERM);
    int status = 0;
    const pid_t waited = waitpid(pid_, &status, 0);
    pid_ = -1;
    return waited > 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  std::string name_, dir_, prefix_;
  pid_t pid_ = -1;
};

}  // namespace depowder::testutil
