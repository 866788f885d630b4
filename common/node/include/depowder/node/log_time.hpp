// The time along an LCM log, with the steps of the recording host's clock taken out.
//
// lcm-logger stamps each event with the system clock of the host it runs on, and lcm-logplayer
// paces a replay by the differences of those stamps. A step of that clock (NTP, an operator)
// stays in the log: after a step back the replay plays what follows as fast as it can, after a
// step forward it waits as long as the step. Every heartbeat carries its process's time on the
// steady clock (uptime_s), which no step moves: two heartbeats of one process that span a gap of
// the event times tell how much time really passed there, so a step is told from a silence.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "depowder/node/log_reader.hpp"

namespace depowder::node {

/// A heartbeat in the log: its event's index, its process (process, host and pid: a restarted
/// process is another) and its uptime_s, us.
struct HeartbeatMark {
  std::size_t event = 0;
  std::string process;
  std::int64_t uptime_us = 0;
};

/// A gap between two events beyond the ordinary: the recorded time going back more than
/// kLogStepTolerance, or nothing for more than kLogSilence.
struct LogGap {
  enum Kind {
    kStep,        ///< the recording clock stepped: the gap is mended to the time that passed
    kSilence,     ///< heartbeats across it tell that the time passed: kept
    kUnexplained  ///< nothing across it tells a silence from a step forward: kept
  };
  Kind kind = kStep;
  std::size_t event = 0;         ///< the event after the gap
  std::int64_t recorded_us = 0;  ///< the gap in the recorded times
  std::int64_t mended_us = 0;    ///< the gap in the mended times
  std::string told_by;           ///< the process whose heartbeats told it ("" for none)
};

/// us without an event beyond which a gap is looked at: a cell's processes send heartbeats at
/// 2 Hz, so a running cell's log never has one.
inline constexpr std::int64_t kLogSilence = 1'000'000;
/// us within which the heartbeats' time and the recorded time agree for a silence (their
/// latencies differ by milliseconds), and the recorded time may run back without a step:
/// lcm-logger's stamps of messages that crossed on the way can (the golden log has one 114 us
/// back).
inline constexpr std::int64_t kLogStepTolerance = 250'000;

struct LogTimes {
  std::vector<std::int64_t> utime;  ///< each event's time, mended
  std::vector<LogGap> gaps;         ///< in order
  std::vector<LogDamage> damage;    ///< mendLogTimes: the log's damaged stretches (log_reader.hpp)
  std::size_t steps() const;        ///< how many gaps were mended
  /// One line on `gap`: what it was, where (seconds into the log) and what was done.
  std::string describe(const LogGap& gap) const;
};

/// Mends `recorded`, the events' times as recorded, with the heartbeats among them. A gap more
/// than kLogStepTolerance back in time is always a step; one of more than kLogSilence is a step
/// when a process's heartbeats across it tell a time that differs by more than kLogStepTolerance. A step is mended to
/// the time the heartbeats tell, or for a step back with no heartbeat across it, to nothing. The other events keep
/// their gaps, so a log without a step keeps its times exactly.
LogTimes mendTimes(const std::vector<std::int64_t>& recorded, const std::vector<HeartbeatMark>& heartbeats);

/// The same for the log at `path` (its heartbeats on `heartbeat_channel`), read with LogReader (a
/// damaged stretch is skipped and named in `damage`); throws if it cannot be read. Heartbeats
/// without uptime_s (recorded before it was sent) tell nothing.
LogTimes mendLogTimes(const std::string& path, const std::string& heartbeat_channel = "HEARTBEAT");

}  // namespace depowder::node
