#include "terminal.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace depowder::eval {

ProgressBar::ProgressBar(std::string title, bool enabled)
    : title_(std::move(title)),
      enabled_(enabled),
      tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

void ProgressBar::update(double done, double total, const std::string& what) {
  if (!enabled_ || total <= 0) return;
  const double f = std::min(1.0, done / total);
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta = f > 0 ? elapsed * (1 - f) / f : 0;
  if (tty_) {
    if (open_ && now - last_draw_ < std::chrono::milliseconds(100) && f < 1) return;
    last_draw_ = now;
    const int width = 30, fill = static_cast<int>(f * width);
    std::string bar(static_cast<std::size_t>(fill), '#');
    bar.append(static_cast<std::size_t>(width - fill), '.');
    std::fprintf(stderr, "\r\033[K%s [%s] %3d%%  %s  %dm%02ds left", title_.c_str(), bar.c_str(),
                 static_cast<int>(f * 100), what.c_str(), static_cast<int>(eta) / 60, static_cast<int>(eta) % 60);
    open_ = true;
  } else {
    const int decile = static_cast<int>(f * 10);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%s: %3d%%  %s  (%.0f s, about %.0f s left)\n", title_.c_str(), decile * 10, what.c_str(),
                 elapsed, eta);
  }
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (open_) std::fprintf(stderr, "\n");
  open_ = false;
}

}  // namespace depowder::eval
