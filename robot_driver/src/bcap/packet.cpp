#include "depowder/robot/bcap/packet.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace depowder::robot::bcap {
namespace {

constexpr int kMaxDepth = 8;  // VARIANT arrays inside VARIANT arrays

// ---- little-endian writer -------------------------------------------------------------------

struct Writer {
  std::vector<std::uint8_t>& out;
  void u8(std::uint8_t v) { out.push_back(v); }
  void u16(std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void patch32(std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
};

std::size_t scalarSize(std::uint16_t type) {
  switch (type) {
    case VT_I2:
    case VT_UI2:
    case VT_BOOL:
      return 2;
    case VT_I4:
    case VT_UI4:
    case VT_R4:
    case VT_ERROR:
      return 4;
    case VT_R8:
    case VT_DATE:
    case VT_I8:
    case VT_UI8:
    case VT_CY:
      return 8;
    case VT_UI1:
      return 1;
    default:
      return 0;
  }
}

bool integerType(std::uint16_t t) {
  return t == VT_I2 || t == VT_I4 || t == VT_UI1 || t == VT_UI4 || t == VT_BOOL || t == VT_ERROR || t == VT_UI2 ||
         t == VT_I8 || t == VT_UI8 || t == VT_CY;
}
bool realType(std::uint16_t t) { return t == VT_R4 || t == VT_R8 || t == VT_DATE; }

void writeScalarNumber(Writer& w, std::uint16_t type, std::int64_t i, double r) {
  switch (type) {
    case VT_I2:
    case VT_BOOL:
      w.u16(static_cast<std::uint16_t>(static_cast<std::int16_t>(i)));
      break;
    case VT_I4:
    case VT_ERROR:
      w.u32(static_cast<std::uint32_t>(static_cast<std::int32_t>(i)));
      break;
    case VT_UI4:
      w.u32(static_cast<std::uint32_t>(i));
      break;
    case VT_UI2:
      w.u16(static_cast<std::uint16_t>(i));
      break;
    case VT_I8:
    case VT_UI8:
    case VT_CY:
      w.u64(static_cast<std::uint64_t>(i));
      break;
    case VT_UI1:
      w.u8(static_cast<std::uint8_t>(i));
      break;
    case VT_R4: {
      const float f = static_cast<float>(r);
      std::uint32_t b;
      std::memcpy(&b, &f, 4);
      w.u32(b);
      break;
    }
    case VT_R8:
    case VT_DATE: {
      std::uint64_t b;
      std::memcpy(&b, &r, 8);
      w.u64(b);
      break;
    }
    default:
      throw std::invalid_argument("b-CAP: cannot encode VARIANT type " + std::to_string(type));
  }
}

void writeVariant(Writer& w, const Variant& v, int depth) {
  if (depth > kMaxDepth) throw std::invalid_argument("b-CAP: VARIANT nesting too deep");
  const std::uint16_t vt = static_cast<std::uint16_t>(v.type | (v.array ? VT_ARRAY : 0));
  const std::uint32_t n = v.count();  // a scalar's is 1, so a scalar without its value is refused
  w.u16(vt);
  w.u32(n);
  if (v.type == VT_EMPTY || v.type == VT_NULL) {
    if (v.array) throw std::invalid_argument("b-CAP: array of EMPTY");
    return;
  }
  if (v.type == VT_BSTR) {
    if (v.strings.size() != n) throw std::invalid_argument("b-CAP: BSTR without a value");
    for (const auto& s : v.strings) {
      w.u32(static_cast<std::uint32_t>(2 * s.size()));
      for (char16_t c : s) w.u16(static_cast<std::uint16_t>(c));
    }
    return;
  }
  if (v.type == VT_VARIANT) {
    if (!v.array) throw std::invalid_argument("b-CAP: a scalar VT_VARIANT cannot be encoded");
    for (const auto& item : v.items) writeVariant(w, item, depth + 1);
    return;
  }
  if (integerType(v.type)) {
    if (v.ints.size() != n) throw std::invalid_argument("b-CAP: integer VARIANT without a value");
    for (std::int64_t i : v.ints) writeScalarNumber(w, v.type, i, 0);
    return;
  }
  if (realType(v.type)) {
    if (v.reals.size() != n) throw std::invalid_argument("b-CAP: real VARIANT without a value");
    for (double r : v.reals) writeScalarNumber(w, v.type, 0, r);
    return;
  }
  throw std::invalid_argument("b-CAP: cannot encode VARIANT type " + std::to_string(v.type));
}

// ---- bounded reader ---------------------------------------------------------------------------

struct Reader {
  Reader(const std::uint8_t* data, std::size_t size) : p(data), n(size) {}
  const std::uint8_t* p;
  std::size_t n;
  std::size_t at = 0;
  std::string error;

  bool need(std::size_t k) {
    if (n - at < k) {
      if (error.empty()) error = "truncated at byte " + std::to_string(at);
      return false;
    }
    return true;
  }
  std::uint16_t u16() {
    const std::uint16_t v = static_cast<std::uint16_t>(p[at] | (p[at + 1] << 8));
    at += 2;
    return v;
  }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[at + i]) << (8 * i);
    at += 4;
    return v;
  }
  std::uint64_t u64() {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[at + i]) << (8 * i);
    at += 8;
    return v;
  }
  bool fail(const std::string& what) {
    if (error.empty()) error = what + " at byte " + std::to_string(at);
    return false;
  }
};

bool readVariant(Reader& r, Variant& v, int depth) {
  if (depth > kMaxDepth) return r.fail("VARIANT nesting deeper than " + std::to_string(kMaxDepth));
  if (!r.need(6)) return false;
  const std::uint16_t vt = r.u16();
  const std::uint32_t count = r.u32();
  v = Variant();
  v.type = static_cast<std::uint16_t>(vt & ~VT_ARRAY);
  v.array = (vt & VT_ARRAY) != 0;
  if (vt & ~(VT_ARRAY | 0x00FF)) return r.fail("unsupported VARIANT type flags " + std::to_string(vt));
  if (!v.array && count != 1) return r.fail("scalar VARIANT with count " + std::to_string(count));
  const std::size_t left = r.n - r.at;

  switch (v.type) {
    case VT_EMPTY:
    case VT_NULL:
      if (v.array) return r.fail("array of EMPTY/NULL");
      return true;
    case VT_BSTR: {
      if (count > left / 4) return r.fail("BSTR count beyond the packet");
      v.strings.reserve(std::min<std::uint32_t>(count, 64));  // each grows as it is read
      for (std::uint32_t k = 0; k < count; ++k) {
        if (!r.need(4)) return false;
        const std::uint32_t bytes = r.u32();
        if (bytes % 2 != 0) return r.fail("BSTR of odd byte length");
        if (!r.need(bytes)) return false;
        std::u16string s(bytes / 2, u'\0');
        for (auto& c : s) c = static_cast<char16_t>(r.u16());
        v.strings.push_back(std::move(s));
      }
      return true;
    }
    case VT_VARIANT: {
      if (!v.array) return r.fail("scalar VT_VARIANT");
      if (count > left / 6) return r.fail("VARIANT array count beyond the packet");
      // Grown as items are read, not sized by the count: nested arrays that each claimed the
      // rest of the packet would otherwise hold ~17 times its length per level before failing.
      v.items.reserve(std::min<std::uint32_t>(count, 64));
      for (std::uint32_t k = 0; k < count; ++k) {
        Variant item;
        if (!readVariant(r, item, depth + 1)) return false;
        v.items.push_back(std::move(item));
      }
      return true;
    }
    default:
      break;
  }
  const std::size_t size = scalarSize(v.type);
  if (size == 0) return r.fail("unsupported VARIANT type " + std::to_string(v.type));
  if (count > left / size) return r.fail("array count beyond the packet");
  if (realType(v.type)) {
    v.reals.reserve(count);
    for (std::uint32_t k = 0; k < count; ++k) {
      if (v.type == VT_R4) {
        const std::uint32_t b = r.u32();
        float f;
        std::memcpy(&f, &b, 4);
        v.reals.push_back(f);
      } else {
        const std::uint64_t b = r.u64();
        double d;
        std::memcpy(&d, &b, 8);
        v.reals.push_back(d);
      }
    }
  } else {
    v.ints.reserve(count);
    for (std::uint32_t k = 0; k < count; ++k) {
      switch (v.type) {
        case VT_I2:
        case VT_BOOL:
          v.ints.push_back(static_cast<std::int16_t>(r.u16()));
          break;
        case VT_I4:
        case VT_ERROR:
          v.ints.push_back(static_cast<std::int32_t>(r.u32()));
          break;
        case VT_UI4:
          v.ints.push_back(r.u32());
          break;
        case VT_UI2:
          v.ints.push_back(r.u16());
          break;
        case VT_I8:
        case VT_UI8:
        case VT_CY:
          v.ints.push_back(static_cast<std::int64_t>(r.u64()));
          break;
        case VT_UI1:
          v.ints.push_back(r.p[r.at++]);
          break;
      }
    }
  }
  return true;
}

}  // namespace

// ---- Variant ----------------------------------------------------------------------------------

Variant Variant::empty() { return Variant(); }
Variant Variant::handle(std::uint32_t h) { return i4(static_cast<std::int32_t>(h)); }
Variant Variant::i2(std::int16_t v) {
  Variant x;
  x.type = VT_I2;
  x.ints = {v};
  return x;
}
Variant Variant::i4(std::int32_t v) {
  Variant x;
  x.type = VT_I4;
  x.ints = {v};
  return x;
}
Variant Variant::ui4(std::uint32_t v) {
  Variant x;
  x.type = VT_UI4;
  x.ints = {v};
  return x;
}
Variant Variant::r4(float v) {
  Variant x;
  x.type = VT_R4;
  x.reals = {v};
  return x;
}
Variant Variant::r8(double v) {
  Variant x;
  x.type = VT_R8;
  x.reals = {v};
  return x;
}
Variant Variant::boolean(bool v) {
  Variant x;
  x.type = VT_BOOL;
  x.ints = {v ? -1 : 0};
  return x;
}
Variant Variant::bstr(const std::string& utf8) {
  Variant x;
  x.type = VT_BSTR;
  x.strings = {toUtf16(utf8)};
  return x;
}
Variant Variant::i4Array(const std::vector<std::int32_t>& v) {
  Variant x;
  x.type = VT_I4;
  x.array = true;
  x.ints.assign(v.begin(), v.end());
  return x;
}
Variant Variant::r8Array(const std::vector<double>& v) {
  Variant x;
  x.type = VT_R8;
  x.array = true;
  x.reals = v;
  return x;
}
Variant Variant::bytes(const std::vector<std::uint8_t>& v) {
  Variant x;
  x.type = VT_UI1;
  x.array = true;
  x.ints.assign(v.begin(), v.end());
  return x;
}
Variant Variant::variants(const std::vector<Variant>& v) {
  Variant x;
  x.type = VT_VARIANT;
  x.array = true;
  x.items = v;
  return x;
}

std::uint32_t Variant::count() const {
  if (!array) return 1;
  switch (type) {
    case VT_BSTR:
      return static_cast<std::uint32_t>(strings.size());
    case VT_VARIANT:
      return static_cast<std::uint32_t>(items.size());
    case VT_R4:
    case VT_R8:
    case VT_DATE:
      return static_cast<std::uint32_t>(reals.size());
    default:
      return static_cast<std::uint32_t>(ints.size());
  }
}

bool Variant::isInteger() const { return integerType(type); }
bool Variant::isReal() const { return realType(type); }

std::optional<std::int64_t> Variant::asInt() const {
  if (array) return std::nullopt;
  if (type == VT_CY && ints.size() == 1)
    return ints[0] % 10000 == 0 ? std::optional<std::int64_t>(ints[0] / 10000) : std::nullopt;
  if (isInteger() && ints.size() == 1) return ints[0];
  if (isReal() && reals.size() == 1 && std::isfinite(reals[0]) && reals[0] == std::floor(reals[0]) &&
      std::abs(reals[0]) < 9e15)
    return static_cast<std::int64_t>(reals[0]);
  return std::nullopt;
}

std::optional<double> Variant::asReal() const {
  if (array) return std::nullopt;
  if (isInteger() && ints.size() == 1) return static_cast<double>(ints[0]) / (type == VT_CY ? 1e4 : 1);
  if (isReal() && reals.size() == 1) return reals[0];
  return std::nullopt;
}

std::optional<std::string> Variant::asString() const {
  if (array || type != VT_BSTR || strings.size() != 1) return std::nullopt;
  return toUtf8(strings[0]);
}

std::optional<std::vector<double>> Variant::asReals() const {
  if (isReal()) return reals;
  if (isInteger()) {
    std::vector<double> out(ints.begin(), ints.end());
    if (type == VT_CY)
      for (double& x : out) x /= 1e4;
    return out;
  }
  return std::nullopt;
}

bool Variant::operator==(const Variant& o) const {
  if (type != o.type || array != o.array || ints != o.ints || strings != o.strings || items != o.items) return false;
  if (reals.size() != o.reals.size()) return false;
  for (std::size_t i = 0; i < reals.size(); ++i) {
    // Bitwise comparison so that NaN payloads compare as the bytes they came from.
    if (std::memcmp(&reals[i], &o.reals[i], sizeof(double)) != 0) return false;
  }
  return true;
}

// ---- packets ----------------------------------------------------------------------------------

std::vector<std::uint8_t> encode(const Packet& packet) {
  if (packet.args.size() > 0xFFFF) throw std::invalid_argument("b-CAP: too many arguments");
  std::vector<std::uint8_t> out;
  out.reserve(64);
  Writer w{out};
  w.u8(kHeader);
  w.u32(0);  // length, patched below
  w.u16(packet.serial);
  w.u16(packet.reserved);
  w.u32(packet.id);
  w.u16(static_cast<std::uint16_t>(packet.args.size()));
  for (const Variant& v : packet.args) {
    const std::size_t at = out.size();
    w.u32(0);
    writeVariant(w, v, 0);
    w.patch32(at, static_cast<std::uint32_t>(out.size() - at - 4));
  }
  w.u8(kFooter);
  if (out.size() > kMaxPacketSize) throw std::invalid_argument("b-CAP: packet larger than kMaxPacketSize");
  w.patch32(1, static_cast<std::uint32_t>(out.size()));
  return out;
}

DecodeResult decode(const std::uint8_t* data, std::size_t size) {
  DecodeResult res;
  if (size == 0 || data == nullptr) {
    res.status = DecodeStatus::Incomplete;
    return res;
  }
  if (data[0] != kHeader) {
    res.error = "header byte is not 0x01";
    return res;
  }
  if (size < 5) {
    res.status = DecodeStatus::Incomplete;
    return res;
  }
  Reader head{data, size};
  head.at = 1;
  const std::uint32_t length = head.u32();
  if (length < kMinPacketSize || length > kMaxPacketSize) {
    res.error = "packet length " + std::to_string(length) + " outside [16, " + std::to_string(kMaxPacketSize) + "]";
    return res;
  }
  res.size = length;
  if (size < length) {
    res.status = DecodeStatus::Incomplete;
    return res;
  }
  if (data[length - 1] != kFooter) {
    res.error = "footer byte is not 0x04";
    return res;
  }
  // Parse the body only up to the footer.
  Reader r{data, length - 1};
  r.at = 5;
  res.packet.serial = r.u16();
  res.packet.reserved = r.u16();
  res.packet.id = r.u32();
  const std::uint16_t argc = r.u16();
  if (static_cast<std::size_t>(argc) * 10 > length - kMinPacketSize) {  // an argument takes >= 10 bytes
    res.error = "argument count " + std::to_string(argc) + " beyond the packet";
    return res;
  }
  res.packet.args.resize(argc);
  for (std::uint16_t k = 0; k < argc; ++k) {
    if (!r.need(4)) {
      res.error = "argument " + std::to_string(k) + ": " + r.error;
      return res;
    }
    const std::uint32_t arg_len = r.u32();
    if (arg_len > r.n - r.at) {
      res.error = "argument " + std::to_string(k) + " length " + std::to_string(arg_len) + " beyond the packet";
      return res;
    }
    Reader sub{data, r.at + arg_len};
    sub.at = r.at;
    if (!readVariant(sub, res.packet.args[k], 0)) {
      res.error = "argument " + std::to_string(k) + ": " + sub.error;
      return res;
    }
    if (sub.at != r.at + arg_len) {
      res.error = "argument " + std::to_string(k) + " length field disagrees with its contents";
      return res;
    }
    r.at += arg_len;
  }
  if (r.at != length - 1) {
    res.error = "trailing bytes before the footer";
    return res;
  }
  res.status = DecodeStatus::Ok;
  return res;
}

std::string functionName(std::uint32_t id) {
  switch (id) {
    case ID_SERVICE_START:
      return "Service_Start";
    case ID_SERVICE_STOP:
      return "Service_Stop";
    case ID_CONTROLLER_CONNECT:
      return "Controller_Connect";
    case ID_CONTROLLER_DISCONNECT:
      return "Controller_Disconnect";
    case ID_CONTROLLER_GETROBOT:
      return "Controller_GetRobot";
    case ID_CONTROLLER_GETVARIABLE:
      return "Controller_GetVariable";
    case ID_CONTROLLER_EXECUTE:
      return "Controller_Execute";
    case ID_ROBOT_GETVARIABLE:
      return "Robot_GetVariable";
    case ID_ROBOT_EXECUTE:
      return "Robot_Execute";
    case ID_ROBOT_CHANGE:
      return "Robot_Change";
    case ID_ROBOT_HALT:
      return "Robot_Halt";
    case ID_ROBOT_MOVE:
      return "Robot_Move";
    case ID_ROBOT_SPEED:
      return "Robot_Speed";
    case ID_ROBOT_RELEASE:
      return "Robot_Release";
    case ID_VARIABLE_GETVALUE:
      return "Variable_GetValue";
    case ID_VARIABLE_PUTVALUE:
      return "Variable_PutValue";
    case ID_VARIABLE_RELEASE:
      return "Variable_Release";
    default:
      return "function " + std::to_string(id);
  }
}

std::string describeHresult(std::uint32_t h) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", h);
  const char* what = nullptr;
  switch (h) {
    case hr::S_OK:
      what = "S_OK";
      break;
    case hr::S_EXECUTING:
      what = "still executing";
      break;
    case hr::E_NOTIMPL:
      what = "not implemented";
      break;
    case hr::E_FAIL:
      what = "failed";
      break;
    case hr::E_ACCESSDENIED:
      what = "access denied";
      break;
    case hr::E_HANDLE:
      what = "invalid handle";
      break;
    case hr::E_INVALIDARG:
      what = "invalid argument";
      break;
    case hr::E_INVALIDPACKET:
      what = "invalid packet";
      break;
    case hr::E_TIMEOUT:
      what = "timeout";
      break;
    case hr::E_MOTOR_OFF:
      what = "motor is off";
      break;
    case hr::E_ARM_NOT_TAKEN:
      what = "arm not taken (TakeArm)";
      break;
    case hr::E_ARM_BUSY:
      what = "arm owned by another client";
      break;
    case hr::E_NOT_SLAVE_MODE:
      what = "not in slave mode";
      break;
    case hr::E_JOINT_LIMIT:
      what = "target outside the joint limits";
      break;
    case hr::E_SPEED_LIMIT:
      what = "target too fast for one cycle";
      break;
    case hr::E_SLAVE_LATE:
      what = "slvMove late (> 16 ms), arm stopped";
      break;
    case hr::E_HALTED:
      what = "arm halted";
      break;
    case hr::E_CONTROLLER_ERROR:
      what = "controller error pending (ClearError)";
      break;
    default:
      break;
  }
  return what ? std::string(buf) + " (" + what + ")" : std::string(buf);
}

std::u16string toUtf16(const std::string& s) {
  std::u16string out;
  out.reserve(s.size());
  std::size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    std::uint32_t cp = 0xFFFD;
    std::size_t len = 1;
    if (c < 0x80) {
      cp = c;
    } else if ((c >> 5) == 0x6 && i + 1 < s.size()) {
      cp = ((c & 0x1F) << 6) | (s[i + 1] & 0x3F);
      len = 2;
    } else if ((c >> 4) == 0xE && i + 2 < s.size()) {
      cp = ((c & 0x0F) << 12) | ((s[i + 1] & 0x3F) << 6) | (s[i + 2] & 0x3F);
      len = 3;
    } else if ((c >> 3) == 0x1E && i + 3 < s.size()) {
      cp = ((c & 0x07) << 18) | ((s[i + 1] & 0x3F) << 12) | ((s[i + 2] & 0x3F) << 6) | (s[i + 3] & 0x3F);
      len = 4;
    }
    i += len;
    if (cp >= 0x10000) {
      cp -= 0x10000;
      out.push_back(static_cast<char16_t>(0xD800 + (cp >> 10)));
      out.push_back(static_cast<char16_t>(0xDC00 + (cp & 0x3FF)));
    } else {
      out.push_back(static_cast<char16_t>(cp));
    }
  }
  return out;
}

std::string toUtf8(const std::u16string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    std::uint32_t cp = s[i];
    if (cp >= 0xD800 && cp < 0xDC00 && i + 1 < s.size() && s[i + 1] >= 0xDC00 && s[i + 1] < 0xE000) {
      cp = 0x10000 + ((cp - 0xD800) << 10) + (s[i + 1] - 0xDC00);
      ++i;
    } else if (cp >= 0xD800 && cp < 0xE000) {
      cp = 0xFFFD;  // lone surrogate
    }
    if (cp < 0x80) {
      out.push_back(static_cast<char>(cp));
    } else if (cp < 0x800) {
      out.push_back(static_cast<char>(0xC0 | (cp >> 6)));
      out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
    } else if (cp < 0x10000) {
      out.push_back(static_cast<char>(0xE0 | (cp >> 12)));
      out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
      out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
    } else {
      out.push_back(static_cast<char>(0xF0 | (cp >> 18)));
      out.push_back(static_cast<char>(0x80 | ((cp >> 12) & 0x3F)));
      out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
      out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
    }
  }
  return out;
}

}  // namespace depowder::robot::bcap
