// A progress bar per experiment on stderr: redrawn in place on a terminal, a line every 10 %
// otherwise (logs, CI).
#pragma once

#include <chrono>
#include <string>

namespace depowder::eval {

class ProgressBar {
 public:
  explicit ProgressBar(std::string title, bool enabled = true);
  ~ProgressBar() { finish(); }
  void update(double done, double total, const std::string& what);
  void finish();

 private:
  std::string title_;
  bool enabled_, tty_, open_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace depowder::eval
