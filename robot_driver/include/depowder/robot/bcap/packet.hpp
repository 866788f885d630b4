// b-CAP packets and VARIANT arguments (REFERENCE.md, "DENSO b-CAP"): encoding to and
// decoding from the wire format. Shared by the client (driver) and the emulator (sim).
//
// Packet: 0x01 | length u32 | serial u16 | reserved u16 | function id / HRESULT u32 |
//         argc u16 | args | 0x04           (little-endian, length counts the whole packet)
// Top-level argument: length u32 (of what follows) | VARIANT.
// VARIANT: type u16 | count u32 | data. Arrays OR the type with 0x2000; the elements of a
// VARIANT array are VARIANTs without the length prefix. A BSTR is a byte length u32 then
// UTF-16LE code units.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace depowder::robot::bcap {

enum VarType : std::uint16_t {
  VT_EMPTY = 0,
  VT_NULL = 1,
  VT_I2 = 2,
  VT_I4 = 3,
  VT_R4 = 4,
  VT_R8 = 5,
  VT_CY = 6,    ///< currency: a 64-bit count of 1/10000
  VT_DATE = 7,  ///< an R8: days since 1899-12-30
  VT_BSTR = 8,
  VT_ERROR = 10,
  VT_BOOL = 11,
  VT_VARIANT = 12,
  VT_UI1 = 17,
  VT_UI2 = 18,
  VT_UI4 = 19,
  VT_I8 = 20,
  VT_UI8 = 21,  ///< kept as its 64 bits in Variant::ints (so decode -> encode is byte-exact)
  VT_ARRAY = 0x2000,
};

/// Function IDs of the subset this project uses (REFERENCE.md).
enum FunctionId : std::uint32_t {
  ID_SERVICE_START = 1,
  ID_SERVICE_STOP = 2,
  ID_CONTROLLER_CONNECT = 3,
  ID_CONTROLLER_DISCONNECT = 4,
  ID_CONTROLLER_GETROBOT = 7,
  ID_CONTROLLER_GETVARIABLE = 9,
  ID_CONTROLLER_EXECUTE = 17,
  ID_ROBOT_GETVARIABLE = 62,
  ID_ROBOT_EXECUTE = 64,
  ID_ROBOT_CHANGE = 66,
  ID_ROBOT_HALT = 70,
  ID_ROBOT_MOVE = 72,
  ID_ROBOT_SPEED = 74,
  ID_ROBOT_RELEASE = 84,
  ID_VARIABLE_GETVALUE = 101,
  ID_VARIABLE_PUTVALUE = 102,
  ID_VARIABLE_RELEASE = 111,
};

/// Return codes (HRESULT). S_OK / S_EXECUTING are the protocol's; the E_* values are the usual
/// COM codes; the controller-specific ones are this project's choice (a real RC8 has its own).
namespace hr {
constexpr std::uint32_t S_OK = 0x00000000;
constexpr std::uint32_t S_EXECUTING = 0x00000900;  ///< "still executing, wait": the final reply follows
constexpr std::uint32_t E_NOTIMPL = 0x80004001;
constexpr std::uint32_t E_FAIL = 0x80004005;
constexpr std::uint32_t E_ACCESSDENIED = 0x80070005;
constexpr std::uint32_t E_HANDLE = 0x80070006;
constexpr std::uint32_t E_INVALIDARG = 0x80070057;
constexpr std::uint32_t E_INVALIDPACKET = 0x80010000;  ///< malformed request
constexpr std::uint32_t E_TIMEOUT = 0x80000900;
constexpr std::uint32_t E_MOTOR_OFF = 0x83204071;         ///< motion command with the motor off
constexpr std::uint32_t E_ARM_NOT_TAKEN = 0x83204072;     ///< motion command without TakeArm
constexpr std::uint32_t E_ARM_BUSY = 0x83204073;          ///< TakeArm while another client owns the arm
constexpr std::uint32_t E_NOT_SLAVE_MODE = 0x83204074;    ///< slvMove outside slave mode
constexpr std::uint32_t E_JOINT_LIMIT = 0x84204075;       ///< target outside the joint limits
constexpr std::uint32_t E_SPEED_LIMIT = 0x84204076;       ///< target too far for one 8 ms cycle
constexpr std::uint32_t E_SLAVE_LATE = 0x84204077;        ///< slvMove later than 16 ms in sync mode
constexpr std::uint32_t E_HALTED = 0x84204078;            ///< the arm was halted (Robot_Halt / error)
constexpr std::uint32_t E_CONTROLLER_ERROR = 0x84204079;  ///< an error is pending; ClearError first
inline bool failed(std::uint32_t h) { return (h & 0x80000000u) != 0; }
}  // namespace hr

/// One VARIANT. Integer types (I2, I4, I8, UI1, UI2, UI4, UI8, CY, BOOL, ERROR) keep their values in
/// `ints` (BOOL as the raw 16-bit value: -1 true, 0 false; CY as its count of 1/10000, which asReal
/// scales), R4 / R8 / DATE in `reals`, BSTR in `strings`
/// (UTF-16 code units, so decode -> encode is byte-exact), VARIANT arrays in `items`.
struct Variant {
  std::uint16_t type = VT_EMPTY;  ///< base type, without VT_ARRAY
  bool array = false;
  std::vector<std::int64_t> ints;
  std::vector<double> reals;
  std::vector<std::u16string> strings;
  std::vector<Variant> items;

  static Variant empty();
  static Variant i2(std::int16_t v);
  static Variant i4(std::int32_t v);
  static Variant ui4(std::uint32_t v);
  /// A handle (controller, robot, variable) as DENSO's clients send it and the controller returns it: VT_I4.
  static Variant handle(std::uint32_t h);
  static Variant r4(float v);
  static Variant r8(double v);
  static Variant boolean(bool v);
  static Variant bstr(const std::string& utf8);
  static Variant i4Array(const std::vector<std::int32_t>& v);
  static Variant r8Array(const std::vector<double>& v);
  static Variant bytes(const std::vector<std::uint8_t>& v);
  static Variant variants(const std::vector<Variant>& v);

  /// Element count on the wire (1 for a scalar, also for EMPTY).
  std::uint32_t count() const;
  bool isInteger() const;  ///< an integer type, CY included (scalar or array)
  bool isReal() const;     ///< R4, R8 or DATE

  /// A scalar integer-like value (integer types, or an integral R4/R8); nullopt otherwise.
  std::optional<std::int64_t> asInt() const;
  /// A scalar number (any integer or real type).
  std::optional<double> asReal() const;
  /// A scalar BSTR as UTF-8.
  std::optional<std::string> asString() const;
  /// Numbers of an array (or a scalar) of an integer or real type.
  std::optional<std::vector<double>> asReals() const;

  bool operator==(const Variant& o) const;
  bool operator!=(const Variant& o) const { return !(*this == o); }
};

struct Packet {
  std::uint16_t serial = 1;    ///< never 0; the reply repeats the request's
  std::uint16_t reserved = 0;  ///< 0 over TCP
  std::uint32_t id = 0;        ///< function id in a request, HRESULT in a reply
  std::vector<Variant> args;

  bool operator==(const Packet& o) const {
    return serial == o.serial && reserved == o.reserved && id == o.id && args == o.args;
  }
};

constexpr std::size_t kMinPacketSize = 16;
constexpr std::size_t kMaxPacketSize = 1 << 20;  ///< larger packets are refused (robustness bound)
constexpr std::uint8_t kHeader = 0x01;
constexpr std::uint8_t kFooter = 0x04;

/// The bytes of `packet`. Throws std::invalid_argument for a variant that cannot be encoded
/// (unknown type, inconsistent array) or a packet above kMaxPacketSize.
std::vector<std::uint8_t> encode(const Packet& packet);

enum class DecodeStatus {
  Ok,
  Incomplete,  ///< fewer bytes than the length field announces (read more)
  Invalid,     ///< not a b-CAP packet, or inconsistent inside (see error)
};

struct DecodeResult {
  DecodeStatus status = DecodeStatus::Invalid;
  Packet packet;
  std::size_t size = 0;  ///< bytes of the packet (from the length field) when known
  std::string error;
};

/// Decodes one packet from the start of `data`. Never reads beyond `size`, never allocates
/// more than the packet's own length justifies.
DecodeResult decode(const std::uint8_t* data, std::size_t size);
inline DecodeResult decode(const std::vector<std::uint8_t>& bytes) { return decode(bytes.data(), bytes.size()); }

/// Human-readable name of a function id ("Robot_Execute") or "function <id>".
std::string functionName(std::uint32_t id);
/// "0x84204077 (slvMove late)" style text for an HRESULT.
std::string describeHresult(std::uint32_t h);

std::u16string toUtf16(const std::string& utf8);
std::string toUtf8(const std::u16string& utf16);

}  // namespace depowder::robot::bcap
