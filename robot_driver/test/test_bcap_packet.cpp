// b-CAP packet encoding against hand-built packets (hex below made with an independent encoder
// written from REFERENCE.md's format, the layout of DENSO's public Python client), decoding of
// replies, and rejection of malformed input.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "depowder/robot/bcap/client.hpp"
#include "depowder/robot/bcap/packet.hpp"

using namespace depowder::robot::bcap;

// Bytes allocated while `g_counting` is set (this binary's every operator new passes here).
static std::atomic<bool> g_counting{false};
static std::atomic<std::size_t> g_allocated{0};
void* operator new(std::size_t n) {
  if (g_counting) g_allocated += n;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
// Not inlined: GCC 12 would see the free() of a pointer from operator new and warn
// (-Wmismatched-new-delete), though the pair is this file's own and matched.
__attribute__((noinline)) void operator delete(void* p) noexcept { std::free(p); }
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

std::vector<std::uint8_t> hex(const std::string& h) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoi(h.substr(i, 2), nullptr, 16)));
  return out;
}

Packet request(std::uint16_t serial, std::uint32_t id, std::vector<Variant> args) {
  Packet p;
  p.serial = serial;
  p.id = id;
  p.args = std::move(args);
  return p;
}

struct Case {
  const char* name;
  Packet packet;
  const char* bytes;
};

std::vector<Case> cases() {
  return {
      {"service_start", request(1, ID_SERVICE_START, {Variant::bstr("")}),
       "011e000000010000000100000001000a0000000800010000000000000004"},
      {"controller_connect",
       request(2, ID_CONTROLLER_CONNECT,
               {Variant::bstr(""), Variant::bstr("CaoProv.DENSO.VRC"), Variant::bstr("localhost"), Variant::bstr("")}),
       "017c000000020000000300000004000a000000080001000000000000002c00000008000100000022000000430061006f00500072006f"
       "0076002e00440045004e0053004f002e005600520043001c000000080001000000120000006c006f00630061006c0068006f0073007400"
       "0a0000000800010000000000000004"},
      {"motor_on", request(4, ID_ROBOT_EXECUTE, Client::robotExecuteArgs(2, "Motor", Variant::i4(1))),
       "0144000000040000004000000003000a00000003000100000002000000140000000800010000000a0000004d006f0074006f0072000a00"
       "00000300010000000100000004"},
      {"take_arm", request(5, ID_ROBOT_EXECUTE, Client::robotExecuteArgs(2, "TakeArm", Variant::i4Array({0, 1}))),
       "014c000000050000004000000003000a00000003000100000002000000180000000800010000000e000000540061006b00650041007200"
       "6d000e000000032002000000000000000100000004"},
      {"slv_change_mode",
       request(6, ID_ROBOT_EXECUTE, Client::robotExecuteArgs(2, "slvChangeMode", Variant::i4(0x202))),
       "0154000000060000004000000003000a00000003000100000002000000240000000800010000001a00000073006c007600430068006100"
       "6e00670065004d006f00640065000a0000000300010000000202000004"},
      {"slv_move",
       request(7, ID_ROBOT_EXECUTE,
               Client::robotExecuteArgs(2, "slvMove", Variant::r8Array({90.0, -45.5, 0.25, 0, 0, 0, 0, 0}))),
       "0184000000070000004000000003000a00000003000100000002000000180000000800010000000e00000073006c0076004d006f007600"
       "65004600000005200800000000000000008056400000000000c046c0000000000000d03f00000000000000000000000000000000000000"
       "00000000000000000000000000000000000000000004"},
      {"put_value", request(8, ID_VARIABLE_PUTVALUE, {Variant::ui4(5), Variant::boolean(true)}),
       "012a000000080000006600000002000a00000013000100000005000000080000000b0001000000ffff04"},
      {"halt", request(9, ID_ROBOT_HALT, {Variant::ui4(2), Variant::bstr("")}),
       "012c000000090000004600000002000a000000130001000000020000000a0000000800010000000000000004"},
      {"give_arm", request(10, ID_ROBOT_EXECUTE, Client::robotExecuteArgs(2, "GiveArm", Variant::empty())),
       "01440000000a0000004000000003000a00000003000100000002000000180000000800010000000e0000004700690076006500410072"
       "006d000600000000000100000004"},
      {"reply_handle", request(3, hr::S_OK, {Variant::ui4(7)}),
       "011e000000030000000000000001000a0000001300010000000700000004"},
      {"reply_executing", request(4, hr::S_EXECUTING, {}), "01100000000400000000090000000004"},
      {"reply_error", request(11, hr::E_SLAVE_LATE, {}), "01100000000b00000077402084000004"},
      {"nested",
       request(12, ID_ROBOT_EXECUTE,
               {Variant::ui4(2), Variant::bstr("x"),
                Variant::variants({Variant::r8Array({1.0}), Variant::i4(3), Variant::bstr("\xc3\xa9\xe2\x82\xac")})}),
       "015e0000000c0000004000000003000a000000130001000000020000000c0000000800010000000200000078002c0000000c20030000"
       "00052001000000000000000000f03f0300010000000300000008000100000004000000e900ac2004"},
  };
}

}  // namespace

TEST(BcapPacket, EncodesHandBuiltPacketsByteForByte) {
  for (const Case& c : cases()) {
    EXPECT_EQ(encode(c.packet), hex(c.bytes)) << c.name;
  }
}

TEST(BcapPacket, DecodesHandBuiltPacketsAndBack) {
  for (const Case& c : cases()) {
    const auto bytes = hex(c.bytes);
    const DecodeResult d = decode(bytes);
    ASSERT_EQ(d.status, DecodeStatus::Ok) << c.name << ": " << d.error;
    EXPECT_EQ(d.size, bytes.size()) << c.name;
    EXPECT_TRUE(d.packet == c.packet) << c.name;
    EXPECT_EQ(encode(d.packet), bytes) << c.name;
  }
}

TEST(BcapPacket, TypedAccessors) {
  const DecodeResult d = decode(hex(cases()[5].bytes));  // slvMove
  ASSERT_EQ(d.status, DecodeStatus::Ok);
  EXPECT_EQ(d.packet.args[0].asInt(), 2);
  EXPECT_EQ(d.packet.args[1].asString(), "slvMove");
  const auto q = d.packet.args[2].asReals();
  ASSERT_TRUE(q.has_value());
  ASSERT_EQ(q->size(), 8u);
  EXPECT_EQ((*q)[0], 90.0);
  EXPECT_EQ((*q)[1], -45.5);
  EXPECT_EQ((*q)[2], 0.25);
  EXPECT_FALSE(d.packet.args[2].asInt().has_value());
  EXPECT_EQ(Variant::boolean(true).asInt(), -1);
  EXPECT_EQ(Variant::r4(2.5f).asReal(), 2.5);
  EXPECT_EQ(Variant::bstr("\xc3\xa9\xe2\x82\xac").strings[0], std::u16string(u"\u00e9\u20ac"));
  EXPECT_EQ(toUtf8(toUtf16("b-CAP \xf0\x9f\xa4\x96")), "b-CAP \xf0\x9f\xa4\x96");  // surrogate pair
}

// The VARIANT types no reply of the session carries but a controller may send (DENSO's clients
// decode them): UI2 65535, I8 -2, UI8 2^64 - 1, CY 12.5 and DATE 45000.5, hand-built.
TEST(BcapPacket, DecodesTheOtherNumberTypes) {
  const auto bytes =
      hex("01640000000300000000000000050008000000120001000000ffff0e000000140001000000feffffffffffffff0e0000001500"
          "01000000ffffffffffffffff0e00000006000100000048e80100000000000e0000000700010000000000000010f9e54004");
  const DecodeResult d = decode(bytes);
  ASSERT_EQ(d.status, DecodeStatus::Ok) << d.error;
  ASSERT_EQ(d.packet.args.size(), 5u);
  const auto& a = d.packet.args;
  EXPECT_EQ(a[0].type, VT_UI2);
  EXPECT_EQ(a[0].asInt(), 65535);
  EXPECT_EQ(a[1].type, VT_I8);
  EXPECT_EQ(a[1].asInt(), -2);
  EXPECT_EQ(a[2].type, VT_UI8);
  EXPECT_EQ(a[2].ints[0], -1);  // its 64 bits
  EXPECT_EQ(a[3].type, VT_CY);
  EXPECT_EQ(a[3].asReal(), 12.5);
  EXPECT_FALSE(a[3].asInt().has_value());  // not a whole number
  EXPECT_EQ(a[4].type, VT_DATE);
  EXPECT_EQ(a[4].asReal(), 45000.5);
  EXPECT_EQ(encode(d.packet), bytes);
}

TEST(BcapPacket, IncompleteAndInvalid) {
  const auto good = hex(cases()[2].bytes);
  // Every proper prefix is incomplete, never invalid or ok.
  for (std::size_t n = 0; n < good.size(); ++n) {
    EXPECT_EQ(decode(good.data(), n).status, DecodeStatus::Incomplete) << n;
  }
  auto bad = good;
  bad[0] = 0x02;
  EXPECT_EQ(decode(bad).status, DecodeStatus::Invalid);
  bad = good;
  bad.back() = 0x05;
  EXPECT_EQ(decode(bad).status, DecodeStatus::Invalid);
  bad = good;
  bad[1] = 10;  // length below the 16-byte minimum
  EXPECT_EQ(decode(bad).status, DecodeStatus::Invalid);
  bad = good;
  bad[13] = 4;  // argc 4 but only 3 arguments
  EXPECT_EQ(decode(bad).status, DecodeStatus::Invalid);
  bad = good;
  bad[15] = 0x40;  // first argument length beyond the packet
  EXPECT_EQ(decode(bad).status, DecodeStatus::Invalid);
  // Huge length fields are refused before anything is allocated.
  std::vector<std::uint8_t> huge = {0x01, 0xff, 0xff, 0xff, 0x7f};
  EXPECT_EQ(decode(huge).status, DecodeStatus::Invalid);
  // An array whose count claims more elements than bytes.
  Packet p = request(1, ID_ROBOT_EXECUTE, {Variant::r8Array({1, 2})});
  auto bytes = encode(p);
  bytes[19] = 0xff;  // count low byte of the first argument
  EXPECT_EQ(decode(bytes).status, DecodeStatus::Invalid);
}

TEST(BcapPacket, RandomVariantsRoundTrip) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> kind(0, 8), len(0, 5);
  std::uniform_real_distribution<double> real(-1e6, 1e6);
  for (int k = 0; k < 2000; ++k) {
    Packet p;
    p.serial = static_cast<std::uint16_t>(1 + rng() % 0xFFFF);
    p.id = static_cast<std::uint32_t>(rng());
    const int n = len(rng);
    for (int i = 0; i < n; ++i) {
      switch (kind(rng)) {
        case 0:
          p.args.push_back(Variant::i4(static_cast<std::int32_t>(rng())));
          break;
        case 1:
          p.args.push_back(Variant::ui4(static_cast<std::uint32_t>(rng())));
          break;
        case 2:
          p.args.push_back(Variant::r8(real(rng)));
          break;
        case 3:
          p.args.push_back(Variant::r4(static_cast<float>(real(rng))));
          break;
        case 4:
          p.args.push_back(Variant::bstr(std::string(len(rng), 'a' + static_cast<char>(rng() % 26))));
          break;
        case 5:
          p.args.push_back(Variant::r8Array(std::vector<double>(len(rng) + 1, real(rng))));
          break;
        case 6:
          p.args.push_back(Variant::boolean(rng() % 2));
          break;
        case 7:
          p.args.push_back(Variant::bytes(std::vector<std::uint8_t>(len(rng) + 1, static_cast<std::uint8_t>(rng()))));
          break;
        default:
          p.args.push_back(Variant::variants({Variant::i2(static_cast<std::int16_t>(rng())), Variant::empty()}));
          break;
      }
    }
    const auto bytes = encode(p);
    const DecodeResult d = decode(bytes);
    ASSERT_EQ(d.status, DecodeStatus::Ok) << d.error;
    ASSERT_TRUE(d.packet == p);
    ASSERT_EQ(encode(d.packet), bytes);
  }
}

TEST(BcapPacket, RefusesUnencodable) {
  Variant v;
  v.type = 99;
  v.ints = {1};
  EXPECT_THROW(encode(request(1, 1, {v})), std::invalid_argument);
  Variant scalar_variant;
  scalar_variant.type = VT_VARIANT;
  EXPECT_THROW(encode(request(1, 1, {scalar_variant})), std::invalid_argument);
  Variant no_value;  // a scalar I4 without its value
  no_value.type = VT_I4;
  EXPECT_THROW(encode(request(1, 1, {no_value})), std::invalid_argument);
}

// Empty arrays are values like any other: decode() took them and encode() refused them, so a
// packet did not survive its own round trip (found by test/fuzz).
TEST(BcapPacket, EmptyArraysRoundTrip) {
  const Packet p = request(1, 1, {Variant::i4Array({}), Variant::r8Array({}), Variant::variants({})});
  const DecodeResult d = decode(encode(p));
  ASSERT_EQ(d.status, DecodeStatus::Ok) << d.error;
  EXPECT_TRUE(d.packet == p);
}

// A packet of the largest size whose VARIANT arrays, nested as deep as allowed and deeper, each
// claim as many items as the rest of the packet could hold. Decoding once sized each array by
// its claim before reading an item: about 17 times the packet's length a level, 150 MB for this
// 1 MiB packet, before the depth check refused it. Arrays now grow as their items are read.
TEST(BcapPacket, NestedArraysAllocateNoMoreThanTheirBytes) {
  std::vector<std::uint8_t> b = {0x01, 0, 0, 0, 0, 1, 0, 0, 0, 0x40, 0, 0, 0, 1, 0};  // serial 1, id 64, 1 arg
  const std::size_t arg_at = b.size();
  b.resize(kMaxPacketSize - 1, 0);
  b.push_back(0x04);
  auto put32 = [&](std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  };
  put32(1, static_cast<std::uint32_t>(b.size()));
  put32(arg_at, static_cast<std::uint32_t>(b.size() - 1 - arg_at - 4));
  for (std::size_t at = arg_at + 4, level = 0; level < 12; ++level, at += 6) {
    b[at] = VT_VARIANT;
    b[at + 1] = VT_ARRAY >> 8;
    put32(at + 2, static_cast<std::uint32_t>((b.size() - at - 6) / 6));
  }
  g_allocated = 0;
  g_counting = true;
  const DecodeResult d = decode(b);
  g_counting = false;
  EXPECT_EQ(d.status, DecodeStatus::Invalid);
  EXPECT_NE(d.error.find("nesting deeper"), std::string::npos) << d.error;
  std::printf("  decoding a 1 MiB packet of nested arrays allocated %zu bytes\n", g_allocated.load());
  EXPECT_LT(g_allocated.load(), b.size());
}
