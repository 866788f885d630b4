// A digest of settings, exact in a double (below 2^52): a heartbeat stat by which processes on
// several hosts, each reading its own cell file, can be checked to share the same values.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

namespace depowder {

class Digest {
 public:
  /// A number, in nano-units: another host's libm may compute a rotation a last bit apart,
  /// which this rounding does not see.
  Digest& add(double v) {
    const std::int64_t n = std::llround(v * 1e9);
    return addBytes(&n, sizeof n);
  }
  Digest& add(const std::string& s) {
    add(static_cast<double>(s.size()));
    return addBytes(s.data(), s.size());
  }
  Digest& addBytes(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) h_ = (h_ ^ bytes[i]) * 1099511628211ull;  // FNV-1a
    return *this;
  }
  double value() const { return static_cast<double>(h_ >> 12); }

 private:
  std::uint64_t h_ = 14695981039346656037ull;
};

}  // namespace depowder
