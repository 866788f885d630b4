// What the fuzz targets share: decoding an LCM message from the input, and the input as a file.
#pragma once

#include <unistd.h>

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
