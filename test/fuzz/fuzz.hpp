// What the fuzz targets share: decoding an LCM message from the input, the input as a file, and
// a mutation of the times of its messages.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace depowder::fuzz {

/// Decodes `msg` from the bytes; a decoder that claims more bytes than it was given aborts.
template <class T>
bool decoded(T& msg, const std::uint8_t* data, std::size_t size) {
  const int n = msg.decode(data, 0, static_cast<int>(size));
  if (n > static_cast<int>(size)) std::abort();
  return n >= 0;
}

/// Calls f(kind, message, length) for each record of the input: [kind byte][length, 2 bytes
/// little-endian][message], the kind taken modulo `kinds`; a record cut short takes what is left.
template <class F>
void forEachRecord(const std::uint8_t* data, std::size_t size, int kinds, F&& f) {
  while (size >= 3) {
    const int kind = data[0] % kinds;
    const std::size_t n = std::min<std::size_t>(size - 3, data[1] | data[2] << 8);
    f(kind, data + 3, n);
    data += 3 + n, size -= 3 + n;
  }
}

/// Sets the utime of one message of an input of records (forEachRecord) to a time that stresses
/// a node's clock: INT64_MIN, INT64_MAX, 0 or -1, its own with one bit flipped or moved 2^k us
/// either way, or another message's time or just before it. Every LCM message the record targets
/// take starts with its int64 utime, big-endian after the 8-byte type fingerprint. False, and the
/// input unchanged, if no message is long enough to hold one. The arithmetic is on the unsigned
/// value: the wrap-around is the point.
inline bool mutateUtime(std::uint8_t* data, std::size_t size, unsigned seed) {
  std::vector<std::uint8_t*> utimes;
  forEachRecord(data, size, 1, [&](int, const std::uint8_t* msg, std::size_t n) {
    if (n >= 16) utimes.push_back(const_cast<std::uint8_t*>(msg) + 8);
  });
  if (utimes.empty()) return false;
  const auto read = [](const std::uint8_t* p) {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v = v << 8 | p[i];
    return v;
  };
  std::minstd_rand rng(seed);
  std::uint8_t* at = utimes[rng() % utimes.size()];
  const std::uint64_t now = read(at);
  const std::uint64_t other = read(utimes[rng() % utimes.size()]);
  const std::uint64_t bit = std::uint64_t{1} << rng() % 64;
  const std::uint64_t int64_min = std::uint64_t{1} << 63;
  const std::uint64_t choices[] = {
      int64_min, int64_min - 1, 0,         ~std::uint64_t{0},  // INT64_MIN, INT64_MAX, 0, -1
      now ^ bit, now + bit,     now - bit,                     // a bit flipped, a jump of 2^k us
      other,     other - 1,                                    // another message's time, or just before
  };
  std::uint64_t v = choices[rng() % std::size(choices)];
  for (int i = 7; i >= 0; --i, v >>= 8) at[i] = static_cast<std::uint8_t>(v);
  return true;
}

/// The bytes as a file of the temp directory named by `extension` (what picks the reader),
/// removed when it goes out of scope.
class TempFile {
 public:
  TempFile(const std::uint8_t* data, std::size_t size, const std::string& extension)
      : path_((std::filesystem::temp_directory_path() / "depowder-fuzz-").string() + std::to_string(::getpid()) +
              extension) {
    std::ofstream(path_, std::ios::binary).write(reinterpret_cast<const char*>(data), static_cast<long>(size));
  }
  ~TempFile() { ::unlink(path_.c_str()); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace depowder::fuzz
