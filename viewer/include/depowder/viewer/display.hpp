// An X display for VTK (Debian's VTK renders only through GLX). Snapshots must work
// on a machine with no display, so the viewer can start a private Xvfb for itself.
#pragma once

#include <sys/types.h>

#include <string>

namespace depowder::viewer {

/// True if $DISPLAY is set and an X server answers on it.
bool displayUsable();

/// A private Xvfb server, started by the constructor and stopped by the destructor.
class Xvfb {
 public:
  /// Starts `Xvfb -displayfd` with a screen of at least width x height and sets $DISPLAY.
  /// Throws std::runtime_error (with the fix: install xvfb) if it cannot start.
  Xvfb(int width, int height);
  ~Xvfb();
  Xvfb(const Xvfb&) = delete;
  Xvfb& operator=(const Xvfb&) = delete;
  const std::string& display() const { return display_; }

 private:
  pid_t pid_ = -1;
  std::string display_;
};

}  // namespace depowder::viewer
