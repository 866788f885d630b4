// Reading an LCM log whose bytes may be damaged.
//
// lcm::LogFile (LCM 1.3) stops at the first damage it meets, as if the log ended there: an event
// header it cannot take (a channel length out of 1..999, a negative data length), an event cut
// short (a logger killed mid-write, a full disk), or bytes after an event that do not begin
// another, which lose that event too ("Invalid header after log data" on stderr). lcm-logplayer
// and every tool on it then miss the rest of the recording. LogReader reads the same format
// (lcm/eventlog.c: each event a big-endian sync word 0xEDA1DA01, event number, time, channel
// length, data length, then the channel and the data; an event that holds the start of another
// and does not end where the log does or another begins was cut short and written after), goes
// on past a damaged stretch to the next whole event, and keeps where each stretch was, so that the tools can say what
// they left out. Every byte of the log is either in an event read or in a stretch it names.
#pragma once

#include <cstdint>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

namespace depowder::node {

/// A stretch of a log's bytes that is not a whole event.
struct LogDamage {
  std::int64_t offset = 0;  ///< its first byte, from the log's start
  std::int64_t bytes = 0;
  bool at_end = false;     ///< it runs to the end of the log
  bool cut_short = false;  ///< at the end, and it starts with an event's header: a recording cut short
};

/// One line on `d`: where it is and what was done with it, e.g. "bytes 100..163 (64) are not an
/// event (damage, or another file's bytes): skipped to the next whole event".
std::string describe(const LogDamage& d);

class LogReader {
 public:
  /// Opens the log at `path`; throws std::runtime_error naming it if it cannot be read.
  explicit LogReader(const std::string& path);
  /// Reads `file` from where it stands (not closed here: tests and fuzzing read from memory).
  explicit LogReader(std::FILE* file);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  /// The next whole event, valid until the next call; nullptr at the end of the log.
  const lcm::LogEvent* next();

  std::size_t events() const { return events_; }                    ///< read so far
  const std::vector<LogDamage>& damage() const { return damage_; }  ///< so far, in order

 private:
  bool readAt(std::int64_t offset, void* into, std::size_t bytes);
  std::int64_t size();  ///< the file's size now (a log being recorded grows)
  void skipped(std::int64_t to, bool at_end);

  std::FILE* file_ = nullptr;
  bool owned_ = false;
  std::int64_t start_ = 0;     ///< where the log begins in the file
  std::int64_t pos_ = 0;       ///< where the search for the next event goes on
  std::int64_t good_end_ = 0;  ///< the end of the last whole event (or the log's start)
  std::int64_t size_ = 0;
  std::size_t events_ = 0;
  std::vector<std::uint8_t> data_;
  lcm::LogEvent event_{};
  std::vector<LogDamage> damage_;
};

}  // namespace depowder::node
