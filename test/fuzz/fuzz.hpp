// What the fuzz targets share: decoding an LCM message from the input, and the input as a file.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

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
