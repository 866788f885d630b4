// An LCM log's bytes, any at all (a log is a file from outside, and a damaged one is what a
// logger killed mid-write leaves): LogReader (log_reader.hpp) must account for every byte once,
// in an event it read or in a damaged stretch it names, in order, and never read past the end.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "depowder/node/log_reader.hpp"

using namespace depowder;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // fmemopen takes no empty buffer
  std::vector<std::uint8_t> bytes(data, data + size);
  std::FILE* file = fmemopen(bytes.data(), bytes.size(), "rb");
  if (file == nullptr) std::abort();
  node::LogReader reader(file);
  // Each event's bytes in order; the damage between and after them fills the rest.
  std::int64_t at = 0;  // where the next event or stretch begins
  std::size_t damage_seen = 0;
  auto stretchesTo = [&](std::int64_t to) {
    const std::vector<node::LogDamage>& d = reader.damage();
    for (; damage_seen < d.size() && d[damage_seen].offset < to; ++damage_seen) {
      if (d[damage_seen].offset != at || d[damage_seen].bytes <= 0 || node::describe(d[damage_seen]).empty())
        std::abort();
      at += d[damage_seen].bytes;
    }
  };
  for (const lcm::LogEvent* e; (e = reader.next()) != nullptr;) {
    const std::int64_t length = 28 + static_cast<std::int64_t>(e->channel.size()) + e->datalen;
    stretchesTo(static_cast<std::int64_t>(size));
    if (e->channel.empty() || e->channel.size() >= 1000 || e->datalen < 0 ||
        at + length > static_cast<std::int64_t>(size))
      std::abort();
    // The event is the bytes there: its channel and data as they stand in the file.
    if (std::memcmp(data + at + 28, e->channel.data(), e->channel.size()) != 0 ||
        (e->datalen > 0 && std::memcmp(data + at + 28 + e->channel.size(), e->data, e->datalen) != 0))
      std::abort();
    at += length;
  }
  stretchesTo(static_cast<std::int64_t>(size) + 1);
  if (at != static_cast<std::int64_t>(size) || damage_seen != reader.damage().size()) std::abort();
  if (reader.next() != nullptr) std::abort();  // the end stays the end
  std::fclose(file);
  return 0;
}
