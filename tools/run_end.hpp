// When depowder-monitor ends a run: every part done and at rest, so the summary's final pose
// error is not taken in the middle of a move. The toppling pipe's air blast once turned it
// 7.5 deg in the run's last second; the run, which then ended 1 s after DONE, reported the
// tracker's pose from before it had followed (6.77 deg).
#pragma once

#include <cstdint>
#include <optional>

#include "depowder/geometry.hpp"

namespace depowder::tools {

/// How long a pose has stayed within a small ball (0.5 deg, 2 mm: a still part's tracked pose
/// wanders 0.01 deg and 0.6 mm from frame to frame).
class Stillness {
 public:
  void see(const Pose& T, std::int64_t now_us) {
    if (!ref_ || rotationDistanceDeg(*ref_, T) > kRotDeg || translationDistance(*ref_, T) > kTransM) {
      ref_ = T;
      since_us_ = now_us;
    }
  }
  bool heard() const { return ref_.has_value(); }
  /// Still for at least `for_us` (false if never seen).
  bool still(std::int64_t now_us, std::int64_t for_us) const { return ref_ && now_us - since_us_ >= for_us; }

  static constexpr double kRotDeg = 0.5, kTransM = 0.002;

 private:
  std::optional<Pose> ref_;
  std::int64_t since_us_ = 0;
};

/// A part is finished when it has been DONE for `hold_us` and both its tracked pose and, where the
/// simulator tells it, its true pose have been still for `hold_us`; or, at the latest, `max_wait_us`
/// after DONE (a part still moving then is reported as such).
struct PartEnd {
  std::int64_t done_since_us = 0;  ///< when first seen DONE (0: not done)
  Stillness tracked, truth;

  static constexpr std::int64_t kHoldUs = 1000000, kMaxWaitUs = 10000000;

  bool atRest(std::int64_t now_us) const {
    return (!tracked.heard() || tracked.still(now_us, kHoldUs)) && (!truth.heard() || truth.still(now_us, kHoldUs));
  }
  bool finished(std::int64_t now_us) const {
    if (done_since_us == 0 || now_us - done_since_us < kHoldUs) return false;
    return atRest(now_us) || now_us - done_since_us >= kMaxWaitUs;
  }
};

}  // namespace depowder::tools
