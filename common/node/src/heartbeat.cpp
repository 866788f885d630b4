#include "depowder/node/heartbeat.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <cmath>

#include "depowder/node/convert.hpp"

namespace depowder::node {

double heartbeatStat(const heartbeat_t& h, const std::string& name) {
  for (std::size_t i = 0; i < h.stat_names.size() && i < h.stat_values.size(); ++i)
    if (h.stat_names[i] == name) return h.stat_values[i];
  return std::nan("");
}

std::string hostName() {
  char buf[256] = {0};
  return gethostname(buf, sizeof(buf) - 1) == 0 ? buf : "unknown";
}

double processCpuSeconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

std::int64_t peakRssKb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss;
}

Heartbeat::Heartbeat(Bus& bus, std::string process, double period_s) : bus_(bus), period_s_(period_s) {
  msg_.process = std::move(process);
  msg_.host = hostName();
  msg_.pid = static_cast<std::int32_t>(getpid());
  msg_.state = heartbeat_t::STARTING;
  start_ = steadyUtime();
  last_cpu_s_ = processCpuSeconds();
}

void Heartbeat::setState(std::int8_t state, std::string reason) {
  msg_.state = state;
  msg_.state_reason = std::move(reason);
}

void Heartbeat::tick() {
  if (steadyUtime() - last_publish_ >= static_cast<std::int64_t>(period_s_ * 1e6)) publish();
}

void Heartbeat::publish() {
  // Periods and CPU shares on the steady clock: a step of the system clock neither silences the
  // heartbeat (one an hour back used to, for an hour) nor skews its CPU share. The stamp is the
  // system clock's, as every message's.
  const std::int64_t now = steadyUtime();
  const double cpu = processCpuSeconds();
  const double wall = last_publish_ > 0 ? (now - last_publish_) * 1e-6 : 0.0;
  msg_.cpu_percent = wall > 0 ? static_cast<float>(100.0 * (cpu - last_cpu_s_) / wall) : 0.f;
  last_cpu_s_ = cpu;
  last_publish_ = now;
  const Bus::Counters c = bus_.counters();
  msg_.utime = nowUtime();
  msg_.received = c.received;
  msg_.published = c.published + 1;  // this heartbeat included
  msg_.decode_errors = c.decode_errors;
  msg_.dropped = dropped_;
  msg_.peak_rss_kb = peakRssKb();
  msg_.stat_names.clear();
  msg_.stat_values.clear();
  for (const auto& [name, value] : stats_) {
    msg_.stat_names.push_back(name);
    msg_.stat_values.push_back(value);
  }
  // The process's time on the steady clock: with it a log's reader tells a step of the recording
  // host's clock from a silence (log_time.hpp).
  msg_.stat_names.push_back("uptime_s");
  msg_.stat_values.push_back((now - start_) * 1e-6);
  msg_.num_stats = static_cast<std::int32_t>(msg_.stat_names.size());
  bus_.publish("HEARTBEAT", msg_);
}

}  // namespace depowder::node
