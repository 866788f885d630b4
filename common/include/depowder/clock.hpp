// The clock-jump rule of every process that orders what it receives by utime.
//
// A message stamped a little older than the newest one taken is late or reordered, and is
// refused or set aside as each process documents. One stamped more than kClockJumpBack older
// is not late: the clock of its source went back. A log was played again into running
// processes, a camera, simulator or host restarted with another clock, or a message stamped in
// the future was taken before it. Refusing it would refuse everything after it until the old
// time comes round again (for a log played twice, its length; for a stamp years ahead, for
// ever), so the process starts its time bookkeeping over instead and says so. The camera proxy
// and the planner do so only once two in a row are far behind: one alone is a bad stamp, refused.
//
// One stamped more than kClockJumpBack further ahead of the newest taken than the time since it
// arrived is a stamp to doubt: a glitch of its source, or its clock jumped forward. The camera
// proxy, where a frame's time enters the cell, refuses such a frame unless the same camera's frame
// before it was refused so and this one runs with it, so one bad stamp never reaches the
// processes downstream nor makes them start over. The planner does the same with its PART_POSE
// and PROGRESS, and the tracker with POINTS, so a stray message stamped ahead does not either.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

namespace depowder {

/// The utimes the processes take, us since the epoch: 0 to 2^53 (the year 2255), where any two
/// differ by an int64 and a double holds each to the microsecond. A message stamped outside is
/// refused (or ignored) by the process that orders or times by it, saying so.
inline constexpr std::int64_t kMaxUtime = std::int64_t{1} << 53;
inline bool utimeInRange(std::int64_t utime) { return utime >= 0 && utime <= kMaxUtime; }
/// What is wrong with a utime outside them, for the refusal's message.
inline std::string utimeOutOfRange(std::int64_t utime) {
  return "utime " + std::to_string(utime) + " us, outside 0 to 2^53 us";
}

/// us a utime must be behind the newest one taken to count as the clock going back: far more
/// than any lateness (the camera proxy waits 40 ms for a time step, the planner holds on a pose
/// 1 s behind), far less than a log played again.
inline constexpr std::int64_t kClockJumpBack = 2'000'000;

/// How far `utime` is behind `newest`, us, as an unsigned difference: no int64 pair overflows it.
inline std::uint64_t behind(std::int64_t newest, std::int64_t utime) {
  return utime < newest ? static_cast<std::uint64_t>(newest) - static_cast<std::uint64_t>(utime) : 0;
}

/// `later` - `earlier` in seconds, for ages and latencies: no int64 pair overflows it (a message's
/// utime is whatever the bus brought), and it is exact to the microsecond up to 2^53 us.
inline double secondsBetween(std::int64_t later, std::int64_t earlier) {
  return (static_cast<double>(later) - static_cast<double>(earlier)) * 1e-6;
}

/// Whether `utime` is more than kClockJumpBack behind `newest`.
inline bool clockWentBack(std::int64_t newest, std::int64_t utime) {
  return behind(newest, utime) > static_cast<std::uint64_t>(kClockJumpBack);
}

/// Whether `utime` is more than kClockJumpBack ahead of `newest`: stamps alone, for a gap between
/// two frames. Not the far-ahead rule, which allows the wall time between them too (a slow
/// camera's frames are seconds apart): see runsAhead.
inline bool clockJumpedAhead(std::int64_t newest, std::int64_t utime) { return clockWentBack(utime, newest); }

/// How far `utime`, arriving at `arrival`, runs ahead of `reference`, which arrived at
/// `reference_arrival`, beyond the wall time between them: us, < 0 behind. The far-ahead rule
/// refuses an input for which this exceeds kClockJumpBack. Utimes in range (utimeInRange) and
/// arrivals from a clock that only moves forward (node::steadyUtime: us since boot): no overflow.
inline std::int64_t runsAhead(std::int64_t reference, std::int64_t reference_arrival, std::int64_t utime,
                              std::int64_t arrival) {
  return utime - reference - std::max<std::int64_t>(0, arrival - reference_arrival);
}

/// The far-ahead rule's memory of one source of stamps: the input it refused last as far ahead.
class AheadWatch {
 public:
  /// For an input at `utime`, arriving at `arrival`, that runs more than kClockJumpBack ahead of
  /// the newest taken: whether it runs within kClockJumpBack of the input refused so just before
  /// it (the clock jumped forward: take it). If not, it is refused, and remembered for the next.
  bool confirms(std::int64_t utime, std::int64_t arrival) {
    const bool yes = refused_ && std::llabs(runsAhead(utime_, arrival_, utime, arrival)) <= kClockJumpBack;
    refused_ = !yes;
    utime_ = utime;
    arrival_ = arrival;
    return yes;
  }
  /// An input not far ahead came: nothing refused to confirm.
  void forget() { refused_ = false; }

 private:
  bool refused_ = false;
  std::int64_t utime_ = 0, arrival_ = 0;  ///< of the input refused last
};

}  // namespace depowder
