// A log's event times and heartbeats as a recording could hold them, any at all (a log is a file
// from outside): mendTimes (log_time.hpp) must keep every ordinary gap as recorded, mend only the
// gaps it names, count no time back, and never overflow (UBSan in the fuzzing build).
//
// Records (fuzz.hpp's forEachRecord): kind 0 an event, kind 1 a heartbeat. Each message: 8 bytes
// little-endian added to the time of the event before (wrapping); a heartbeat's next byte picks
// one of four processes, and its next 8 bytes are added to that process's uptime.
#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include "depowder/node/log_time.hpp"
#include "fuzz.hpp"

using namespace depowder;
using node::LogGap;

namespace {

/// Up to 8 bytes from `data` as a little-endian int64, and how many were taken.
std::int64_t int64At(const std::uint8_t* data, std::size_t size, std::size_t* taken) {
  std::uint64_t v = 0;
  *taken = std::min<std::size_t>(size, 8);
  for (std::size_t k = 0; k < *taken; ++k) v |= std::uint64_t{data[k]} << (8 * k);
  return static_cast<std::int64_t>(v);
}

std::int64_t wrap(std::uint64_t v) { return static_cast<std::int64_t>(v); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::int64_t> recorded;
  std::vector<node::HeartbeatMark> heartbeats;
  std::int64_t uptime[4] = {0, 0, 0, 0};
  fuzz::forEachRecord(data, size, 2, [&](int kind, const std::uint8_t* m, std::size_t n) {
    std::size_t taken = 0;
    const std::int64_t delta = int64At(m, n, &taken);
    const std::uint64_t before = recorded.empty() ? 0 : static_cast<std::uint64_t>(recorded.back());
    if (kind == 1 && taken < n) {
      const int process = m[taken] % 4;
      std::size_t more = 0;
      const std::int64_t step = int64At(m + taken + 1, n - taken - 1, &more);
      uptime[process] = wrap(static_cast<std::uint64_t>(uptime[process]) + static_cast<std::uint64_t>(step));
      heartbeats.push_back({recorded.size(), "process " + std::to_string(process), uptime[process]});
    }
    recorded.push_back(wrap(before + static_cast<std::uint64_t>(delta)));
  });

  const node::LogTimes times = node::mendTimes(recorded, heartbeats);
  if (times.utime.size() != recorded.size()) std::abort();
  if (recorded.empty()) return 0;
  if (times.utime.front() != recorded.front()) std::abort();
  std::size_t next = 0;  // the next gap named
  for (std::size_t i = 1; i < recorded.size(); ++i) {
    const std::int64_t as_recorded =
        wrap(static_cast<std::uint64_t>(recorded[i]) - static_cast<std::uint64_t>(recorded[i - 1]));
    const std::int64_t as_mended =
        wrap(static_cast<std::uint64_t>(times.utime[i]) - static_cast<std::uint64_t>(times.utime[i - 1]));
    if (next < times.gaps.size() && times.gaps[next].event == i) {
      const LogGap& g = times.gaps[next++];
      if (g.recorded_us != as_recorded || g.mended_us != as_mended) std::abort();
      if (g.kind == LogGap::kStep ? g.mended_us < 0 : g.mended_us != g.recorded_us) std::abort();
      if (times.describe(g).empty()) std::abort();
    } else if (as_mended != as_recorded || as_recorded < -node::kLogStepTolerance || as_recorded > node::kLogSilence) {
      std::abort();  // an ordinary gap changed, or an unordinary one not named
    }
  }
  if (next != times.gaps.size()) std::abort();  // gaps out of order, or at no event
  return 0;
}
