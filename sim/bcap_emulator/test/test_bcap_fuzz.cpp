// Fuzzing the b-CAP emulator (bounded): random bytes, truncated and bit-flipped valid packets
// over TCP, and random well-formed requests straight into the request handler. The emulator
// must stay up and still serve a proper session afterwards.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <random>

#include "depowder/robot/bcap/client.hpp"
#include "depowder/sim/bcap_emulator.hpp"

using namespace depowder;
using namespace depowder::robot::bcap;
using depowder::sim::BcapEmulator;

namespace {

int connectTo(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Reads whatever comes back within `ms`; false if the peer closed the connection.
bool drain(int fd, int ms) {
  pollfd p{fd, POLLIN, 0};
  while (::poll(&p, 1, ms) > 0) {
    std::uint8_t buf[4096];
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) return false;
    if (n < 0) return errno == EAGAIN;
    ms = 1;
  }
  return true;
}

std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> s;
  auto add = [&](std::uint32_t id, std::vector<Variant> args) {
    Packet p;
    p.serial = 1;
    p.id = id;
    p.args = std::move(args);
    s.push_back(encode(p));
  };
  add(ID_SERVICE_START, {Variant::bstr("")});
  add(ID_CONTROLLER_CONNECT,
      {Variant::bstr(""), Variant::bstr("CaoProv.DENSO.VRC"), Variant::bstr("localhost"), Variant::bstr("")});
  add(ID_ROBOT_EXECUTE, {Variant::ui4(2), Variant::bstr("slvMove"), Variant::r8Array({1, 2, 3, 4, 5, 6, 0, 0})});
  add(ID_ROBOT_EXECUTE, {Variant::ui4(2), Variant::bstr("TakeArm"), Variant::i4Array({0, 1})});
  add(ID_VARIABLE_PUTVALUE, {Variant::ui4(3), Variant::boolean(true)});
  add(ID_ROBOT_EXECUTE, {Variant::ui4(2), Variant::bstr("x"),
                         Variant::variants({Variant::r8Array({1.0}), Variant::i4(3), Variant::bstr("ab")})});
  return s;
}

Variant randomVariant(std::mt19937& rng, int depth = 0) {
  switch (rng() % (depth < 2 ? 9 : 8)) {
    case 0:
      return Variant::i4(static_cast<std::int32_t>(rng() % 8));
    case 1:
      return Variant::ui4(rng() % 8);
    case 2:
      return Variant::r8Array(std::vector<double>(rng() % 10, static_cast<double>(rng() % 400) - 200));
    case 3:
      return Variant::bstr(std::vector<std::string>{"Motor", "TakeArm", "GiveArm", "slvChangeMode", "slvMove", "CurJnt",
                                                    "ClearError", "IO24", "", "CaoProv.DENSO.VRC"}[rng() % 10]);
    case 4:
      return Variant::boolean(rng() % 2);
    case 5:
      return Variant::empty();
    case 6:
      return Variant::i4Array({static_cast<std::int32_t>(rng() % 0x300), static_cast<std::int32_t>(rng() % 2)});
    case 7:
      return Variant::r4(static_cast<float>(rng() % 100));
    default: {
      std::vector<Variant> items(rng() % 4);
      for (auto& v : items) v = randomVariant(rng, depth + 1);
      return Variant::variants(items);
    }
  }
}

}  // namespace

TEST(BcapFuzz, EmulatorSurvivesGarbageOverTcp) {
  sim::BcapEmulatorConfig cfg;
  cfg.port = 0;
  cfg.motor_on_time_s = 0.0;
  BcapEmulator emu(cfg);
  ASSERT_TRUE(emu.start());
  std::mt19937 rng(2024);
  const auto seed_packets = seeds();
  int fd = connectTo(emu.port());
  ASSERT_GE(fd, 0);
  int reconnects = 0;
  const int kCount = 3000;
  for (int k = 0; k < kCount; ++k) {
    std::vector<std::uint8_t> bytes;
    const auto& seed = seed_packets[rng() % seed_packets.size()];
    switch (k % 4) {
      case 0:  // random bytes, sometimes with a plausible header
        bytes.resize(1 + rng() % 64);
        for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
        if (rng() % 2) bytes[0] = kHeader;
        break;
      case 1:  // a truncated valid packet followed by a valid one
        bytes.assign(seed.begin(), seed.begin() + static_cast<std::ptrdiff_t>(rng() % seed.size()));
        bytes.insert(bytes.end(), seed.begin(), seed.end());
        break;
      case 2: {  // bit flips inside a valid packet
        bytes = seed;
        const int flips = 1 + rng() % 4;
        for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      }
      default:  // a valid frame with a corrupted length field inside an argument
        bytes = seed;
        if (bytes.size() > 20) bytes[15 + rng() % 4] = static_cast<std::uint8_t>(rng());
        break;
    }
    if (::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) < 0 || !drain(fd, k % 50 == 0 ? 5 : 0)) {
      ::close(fd);
      fd = connectTo(emu.port());
      ASSERT_GE(fd, 0) << "emulator stopped accepting after " << k << " packets";
      ++reconnects;
    }
    // Occasionally start over so that half-read frames do not swallow everything after them.
    if (k % 10 == 9) {
      ::close(fd);
      fd = connectTo(emu.port());
      ASSERT_GE(fd, 0);
    }
  }
  ::close(fd);
  const auto st = emu.stats();
  std::printf("fuzz: %d inputs, %lld requests decoded, %lld malformed, %lld error replies, %d forced reconnects\n",
              kCount, static_cast<long long>(st.packets), static_cast<long long>(st.malformed),
              static_cast<long long>(st.error_replies), reconnects);
  EXPECT_GT(st.malformed, 100);
  // Still serving a proper session.
  ClientConfig cc;
  cc.port = emu.port();
  Client c(cc);
  ASSERT_TRUE(c.connect().ok());
  ASSERT_TRUE(c.serviceStart("").ok());
  const auto ctrl = c.controllerConnect("", "CaoProv.DENSO.VRC", "localhost", "");
  ASSERT_TRUE(ctrl.ok()) << ctrl.error;
  const auto rob = c.controllerGetRobot(*ctrl.handle(), "Arm");
  ASSERT_TRUE(rob.ok());
  EXPECT_TRUE(c.robotExecute(*rob.handle(), "CurJnt").ok());
}

TEST(BcapFuzz, RandomWellFormedRequestsIntoTheHandler) {
  sim::BcapEmulatorConfig cfg;
  cfg.port = 0;
  cfg.motor_on_time_s = 0.0;
  cfg.cycle_s = 0.0005;  // keep sync-mode waits short
  BcapEmulator emu(cfg);
  std::mt19937 rng(7);
  const std::uint32_t ids[] = {ID_SERVICE_START,       ID_SERVICE_STOP,
                               ID_CONTROLLER_CONNECT,  ID_CONTROLLER_DISCONNECT,
                               ID_CONTROLLER_GETROBOT, ID_CONTROLLER_GETVARIABLE,
                               ID_CONTROLLER_EXECUTE,  ID_ROBOT_EXECUTE,
                               ID_ROBOT_HALT,          ID_ROBOT_RELEASE,
                               ID_VARIABLE_GETVALUE,   ID_VARIABLE_PUTVALUE,
                               ID_VARIABLE_RELEASE,    12345};
  int ok = 0;
  for (int k = 0; k < 20000; ++k) {
    Packet p;
    p.serial = static_cast<std::uint16_t>(1 + k % 0xFFFE);
    p.id = ids[rng() % (sizeof ids / sizeof ids[0])];
    const int n = static_cast<int>(rng() % 5);
    for (int i = 0; i < n; ++i) p.args.push_back(randomVariant(rng));
    const Packet rep = emu.handle(p, 1 + static_cast<int>(rng() % 3));
    ASSERT_EQ(rep.serial, p.serial);
    if (rep.id == hr::S_OK) ++ok;
    if (k % 1000 == 999) emu.connectionClosed(1 + static_cast<int>(rng() % 3));
  }
  std::printf("handler fuzz: 20000 requests, %d answered S_OK\n", ok);
  EXPECT_GT(ok, 100);
  // Joint state stays within limits whatever was accepted.
  const auto j = emu.joints();
  const robot::ArmConfig arm;
  for (int i = 0; i < 6; ++i) {
    EXPECT_GE(j.q[i], arm.q_min[i] - 1e-9);
    EXPECT_LE(j.q[i], arm.q_max[i] + 1e-9);
  }
}
