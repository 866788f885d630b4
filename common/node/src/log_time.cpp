#include "depowder/node/log_time.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/heartbeat.hpp"

namespace depowder::node {

namespace {

/// a - b and a + b, wrapping rather than overflowing: a log's times are whatever was written in it.
std::int64_t minus(std::int64_t a, std::int64_t b) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b));
}
std::int64_t plus(std::int64_t a, std::int64_t b) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(b));
}

}  // namespace

std::size_t LogTimes::steps() const {
  return static_cast<std::size_t>(
      std::count_if(gaps.begin(), gaps.end(), [](const LogGap& g) { return g.kind == LogGap::kStep; }));
}

std::string LogTimes::describe(const LogGap& gap) const {
  const double at = minus(utime[gap.event], utime.front()) * 1e-6;
  char head[128];
  if (gap.kind == LogGap::kStep) {
    std::snprintf(head, sizeof head, "the recording host's clock stepped %+.3f s at %.2f s into the log",
                  minus(gap.recorded_us, gap.mended_us) * 1e-6, at);
    return head + (gap.told_by.empty() ? std::string(" (the recorded time went back, and no heartbeat across it "
                                                     "tells how much time passed: none is counted)")
                                       : " (told by the heartbeats of " + gap.told_by + ")");
  }
  std::snprintf(head, sizeof head, "no event for %.3f s at %.2f s into the log", gap.recorded_us * 1e-6, at);
  return head + (gap.kind == LogGap::kSilence
                     ? " (a silence, as the heartbeats of " + gap.told_by + " tell): kept"
                     : std::string(" (no heartbeat across it tells a silence from a step of the clock forward): kept"));
}

LogTimes mendTimes(const std::vector<std::int64_t>& recorded, const std::vector<HeartbeatMark>& heartbeats) {
  const std::size_t n = recorded.size();
  LogTimes out;
  out.utime = recorded;
  if (n < 2) return out;
  // gap(i): from event i - 1 to event i. ordinary[k], suspects[k]: the sum of the ordinary gaps
  // and the count of the others among gaps 1..k.
  auto gap = [&](std::size_t i) { return minus(recorded[i], recorded[i - 1]); };
  auto suspect = [](std::int64_t g) { return g < -kLogStepTolerance || g > kLogSilence; };
  std::vector<std::int64_t> ordinary(n, 0);
  std::vector<std::size_t> suspects(n, 0);
  for (std::size_t i = 1; i < n; ++i) {
    const std::int64_t g = gap(i);
    ordinary[i] = plus(ordinary[i - 1], suspect(g) ? 0 : g);
    suspects[i] = suspects[i - 1] + suspect(g);
  }
  std::map<std::string, std::vector<const HeartbeatMark*>> streams;  // each process's, in log order
  for (const HeartbeatMark& h : heartbeats)
    if (h.event < n) streams[h.process].push_back(&h);

  for (std::size_t i = 1; i < n; ++i) {
    const std::int64_t g = gap(i);
    std::int64_t mended = g;
    if (suspect(g)) {
      // The time that passed over the gap: a process's two heartbeats a and b across it (no other
      // such gap between them), the steady time between them less the ordinary gaps beside it.
      // The pair nearest in time tells it best.
      LogGap found{LogGap::kUnexplained, i, g, g, ""};
      std::int64_t best_span = -1, passed = 0;
      for (const auto& [process, marks] : streams) {
        const auto b = std::lower_bound(marks.begin(), marks.end(), i,
                                        [](const HeartbeatMark* h, std::size_t e) { return h->event < e; });
        if (b == marks.begin() || b == marks.end()) continue;
        const HeartbeatMark& hb = **b;
        const HeartbeatMark& ha = **(b - 1);
        const std::int64_t span = minus(hb.uptime_us, ha.uptime_us);
        if (span < 0 || suspects[hb.event] - suspects[ha.event] != 1 || (best_span >= 0 && span >= best_span)) continue;
        best_span = span;
        passed = std::max<std::int64_t>(0, minus(span, minus(ordinary[hb.event], ordinary[ha.event])));
        found.told_by = process;
      }
      if (best_span < 0) {
        if (g < 0) found.kind = LogGap::kStep, mended = 0;
      } else if (const std::int64_t off = minus(g, passed); off > kLogStepTolerance || off < -kLogStepTolerance) {
        found.kind = LogGap::kStep, mended = passed;
      } else {
        found.kind = LogGap::kSilence;
      }
      found.mended_us = mended;
      out.gaps.push_back(found);
    }
    out.utime[i] = plus(out.utime[i - 1], mended);
  }
  return out;
}

LogTimes mendLogTimes(const std::string& path, const std::string& heartbeat_channel) {
  LogReader log(path);
  std::vector<std::int64_t> recorded;
  std::vector<HeartbeatMark> heartbeats;
  for (const lcm::LogEvent* e; (e = log.next()) != nullptr;) {
    if (e->channel == heartbeat_channel) {
      heartbeat_t h;
      try {  // garbage can make the generated decoder throw (a string length beyond the message)
        const double uptime = h.decode(e->data, 0, e->datalen) < 0 ? NAN : heartbeatStat(h, "uptime_s");
        if (std::isfinite(uptime) && uptime >= 0 && uptime < 1e12)
          heartbeats.push_back({recorded.size(), h.process + " on " + h.host + " (pid " + std::to_string(h.pid) + ")",
                                std::llround(uptime * 1e6)});
      } catch (const std::exception&) {
      }
    }
    recorded.push_back(e->timestamp);
  }
  LogTimes times = mendTimes(recorded, heartbeats);
  times.damage = log.damage();
  return times;
}

}  // namespace depowder::node
