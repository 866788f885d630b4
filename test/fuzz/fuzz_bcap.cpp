// b-CAP packets from the wire (client.cpp and the emulator decode the same way): decode() must
// never crash, read past the end or claim more bytes than it was given, and a packet it accepts
// must encode back to bytes that decode to the same packet.
#include <cstdlib>

#include "depowder/robot/bcap/packet.hpp"

using namespace depowder::robot::bcap;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const DecodeResult r = decode(data, size);
  if (r.status != DecodeStatus::Ok) return 0;
  if (r.size > size) std::abort();
  const DecodeResult again = decode(encode(r.packet));
  if (again.status != DecodeStatus::Ok || again.packet.id != r.packet.id || again.packet.args != r.packet.args)
    std::abort();
  return 0;
}
