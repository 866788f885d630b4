// Groups the frames of several cameras into time steps (matching by utime within a
// tolerance) and releases each time step once every expected camera has contributed
// or once it has waited max_wait, so a missing or dead camera never stalls the stream.
//
// Two clocks: `utime` is the capture time a frame carries (matching, staleness; works
// for replayed logs), `now` / `arrival` is a clock of this process that only moves forward
// (waiting, silence; depowder-camera's node::steadyUtime, so a step of the system clock neither
// stretches nor cuts them). Both in microseconds; the caller passes them, so tests control time.
//
// The capture clock going back (depowder/clock.hpp) is told from a camera whose clock runs
// behind the others: only when every camera heard within silent_after has sent a frame more
// than kClockJumpBack behind the last time step published does the merger start over. The
// time steps still waiting go out as they are, and the new frames are grouped from scratch.
//
// A frame whose utime ran more than kClockJumpBack ahead of the time passed since the newest frame
// taken is refused (kAhead) unless the same camera's frame before it was refused so and this one
// runs within kClockJumpBack of it: one bad stamp changes nothing, a clock that jumped forward
// loses one frame per camera, and frames far apart in time (a slow camera, a silence) are not ahead.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "depowder/clock.hpp"
#include "depowder/geometry.hpp"
#include "depowder/perception/config.hpp"
#include "depowder/perception/status.hpp"

namespace depowder::perception {

struct CameraFrame {
  std::string camera;
  std::int64_t utime = 0;  ///< capture time, us
  Cloud points;            ///< cell frame
};

struct MergedFrame {
  std::int64_t utime = 0;            ///< newest utime among the sources
  std::vector<CameraFrame> sources;  ///< sorted by camera name
  std::vector<std::string> missing;  ///< cameras that were expected but did not contribute
};

struct CameraHealth {
  std::string name;
  std::int64_t frames = 0;    ///< frames accepted
  double last_seen_age = -1;  ///< s since the last frame arrived; -1 = never
  double utime_lag = 0;       ///< s its newest utime lags the newest of all cameras
  bool silent = false;        ///< never seen, or nothing for silent_after (then not waited for)
  bool stale = false;         ///< utime_lag > stale_after (then not waited for)
  /// Silent, but its frames come and are refused before merging (CameraProxy::health): the last
  /// one's reason; "" otherwise.
  std::string refused;
};

class FrameMerger {
 public:
  /// `known_cameras` (e.g. from the cell YAML) are reported by health() even before (or
  /// if never) they send anything, and are waited for during the first silent_after after
  /// the first frame arrives; a camera that is neither known nor seen is never waited for.
  explicit FrameMerger(MergerConfig config = {}, std::vector<std::string> known_cameras = {});

  /// Files a frame under its time step. kLate: its time step was already released;
  /// kDuplicate: the same camera already has a frame with this utime waiting; kAhead: far ahead
  /// of the newest frame, not confirmed. The frame that completes a clock going back is filed as
  /// the first of the new time steps.
  FrameError add(CameraFrame frame, std::int64_t arrival);

  /// Time steps ready at `now`, oldest first (utime strictly increasing across calls, but for
  /// the clock going back).
  std::vector<MergedFrame> poll(std::int64_t now);

  /// Wall-clock time (us) at which the oldest waiting time step times out; 0 if none waits.
  std::int64_t nextDeadline() const;

  /// Every camera seen or known, sorted by name.
  std::vector<CameraHealth> health(std::int64_t now) const;

  std::size_t pending() const { return pending_.size(); }
  /// Cameras known or seen, and whether `name` is one.
  std::size_t cameras() const { return cameras_.size(); }
  bool knows(const std::string& name) const { return cameras_.count(name) > 0; }

  /// Times the capture clock went back and the merger started over, and the last one, said.
  std::int64_t restarts() const { return restarts_; }
  const std::string& lastRestart() const { return last_restart_; }

 private:
  struct Group {
    std::int64_t utime = 0;          ///< utime of the first frame (matching reference)
    std::int64_t first_arrival = 0;  ///< `now` clock
    std::map<std::string, CameraFrame> frames;
  };
  struct Camera {
    std::int64_t frames = 0;        ///< accepted
    std::int64_t last_arrival = 0;  ///< 0 = never
    std::int64_t last_utime = 0;
    int back_frames = 0;          ///< its frames in a row far behind the last time step published...
    std::int64_t back_utime = 0;  ///< ...the newest of them (0 if none)
    AheadWatch ahead;             ///< its last frame, if refused as far ahead
  };
  /// Waited for: seen within silent_after and not stale.
  bool expected(const Camera& c, std::int64_t now) const;
  bool stale(const Camera& c) const;
  MergedFrame release(Group&& group, std::int64_t now) const;
  /// Starts over if every camera heard within silent_after has gone back, by two frames in all at
  /// least: one frame alone from the only camera heard is a bad stamp until another confirms it.
  void restartIfClockWentBack(std::int64_t arrival);

  MergerConfig config_;
  std::map<std::string, Camera> cameras_;
  std::vector<Group> pending_;               ///< sorted by utime
  std::vector<MergedFrame> flushed_;         ///< time steps of the old clock, released at the next poll
  std::int64_t released_utime_ = INT64_MIN;  ///< reference utime of the last released group
  std::int64_t newest_utime_ = INT64_MIN;
  std::int64_t newest_arrival_ = 0;  ///< of the frame of newest_utime_ (`now` clock)
  std::int64_t start_ = 0;           ///< arrival of the first frame (`now` clock)
  std::int64_t restarts_ = 0;
  std::string last_restart_;
};

}  // namespace depowder::perception
