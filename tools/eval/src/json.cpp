#include "depowder/eval/json.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "depowder/files.hpp"

namespace depowder::eval {

Json& Json::push(Json value) {
  if (type_ != Type::kArray) throw JsonError("push on a JSON value that is not an array");
  array_.push_back(std::move(value));
  return array_.back();
}

Json& Json::set(const std::string& key, Json value) {
  if (type_ != Type::kObject) throw JsonError("set('" + key + "') on a JSON value that is not an object");
  for (auto& [k, v] : object_)
    if (k == key) return v = std::move(value);
  object_.emplace_back(key, std::move(value));
  return object_.back().second;
}

bool Json::has(const std::string& key) const {
  if (type_ != Type::kObject) return false;
  for (const auto& kv : object_)
    if (kv.first == key) return true;
  return false;
}

const Json& Json::at(const std::string& key) const {
  if (type_ != Type::kObject) throw JsonError("'" + key + "' looked up in a JSON value that is not an object");
  for (const auto& kv : object_)
    if (kv.first == key) return kv.second;
  throw JsonError("missing key '" + key + "'");
}

const Json& Json::at(std::size_t i) const {
  if (type_ != Type::kArray || i >= array_.size()) throw JsonError("JSON index " + std::to_string(i) + " out of range");
  return array_[i];
}

std::size_t Json::size() const { return type_ == Type::kArray ? array_.size() : object_.size(); }

bool Json::boolean() const {
  if (type_ != Type::kBool) throw JsonError("JSON value is not a boolean");
  return bool_;
}

double Json::number() const {
  if (type_ == Type::kNull) return std::nan("");
  if (type_ != Type::kNumber) throw JsonError("JSON value is not a number");
  return number_;
}

const std::string& Json::string() const {
  if (type_ != Type::kString) throw JsonError("JSON value is not a string");
  return string_;
}

namespace {

void escape(std::string& out, const std::string& s) {
  out += '"';
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  out += '"';
}

void newline(std::string& out, int indent, int depth) {
  if (indent <= 0) return;
  out += '\n';
  out.append(static_cast<std::size_t>(indent * depth), ' ');
}

}  // namespace

void Json::dumpTo(std::string& out, int indent, int depth) const {
  switch (type_) {
    case Type::kNull:
      out += "null";
      return;
    case Type::kBool:
      out += bool_ ? "true" : "false";
      return;
    case Type::kNumber: {
      if (!std::isfinite(number_)) {
        out += "null";
        return;
      }
      // The shortest form that reads back as the same double: a report re-rendered from the
      // JSON (`report --from`) compares the methods' figures exactly as the run did.
      char buf[32];
      for (int digits = 15; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, number_);
        if (std::strtod(buf, nullptr) == number_) break;
      }
      out += buf;
      return;
    }
    case Type::kString:
      escape(out, string_);
      return;
    case Type::kArray: {
      out += '[';
      // Arrays of plain numbers stay on one line.
      bool flat = true;
      for (const Json& v : array_) flat = flat && (v.type_ != Type::kArray && v.type_ != Type::kObject);
      for (std::size_t i = 0; i < array_.size(); ++i) {
        if (i) out += flat ? ", " : ",";
        if (!flat) newline(out, indent, depth + 1);
        array_[i].dumpTo(out, indent, depth + 1);
      }
      if (!flat && !array_.empty()) newline(out, indent, depth);
      out += ']';
      return;
    }
    case Type::kObject: {
      out += '{';
      for (std::size_t i = 0; i < object_.size(); ++i) {
        if (i) out += ',';
        newline(out, indent, depth + 1);
        escape(out, object_[i].first);
        out += indent > 0 ? ": " : ":";
        object_[i].second.dumpTo(out, indent, depth + 1);
      }
      if (!object_.empty()) newline(out, indent, depth);
      out += '}';
      return;
    }
  }
}

std::string Json::dump(int indent) const {
  std::string out;
  dumpTo(out, indent, 0);
  return out;
}

namespace {

class Parser {
 public:
  explicit Parser(const std::string& text) : s_(text) {}

  Json document() {
    Json v = value();
    skip();
    if (i_ != s_.size()) fail("trailing characters");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw JsonError("JSON parse error at offset " + std::to_string(i_) + ": " + what);
  }
  void skip() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\n' || s_[i_] == '\t' || s_[i_] == '\r')) ++i_;
  }
  bool literal(const char* word) {
    const std::string w(word);
    if (s_.compare(i_, w.size(), w) != 0) return false;
    i_ += w.size();
    return true;
  }
  Json value() {
    skip();
    if (i_ >= s_.size()) fail("unexpected end");
    const char c = s_[i_];
    if (c == '{' || c == '[') {
      if (depth_ >= kMaxDepth) fail("nested deeper than " + std::to_string(kMaxDepth));
      ++depth_;
      Json nested = c == '{' ? object() : array();
      --depth_;
      return nested;
    }
    if (c == '"') return Json(string());
    if (literal("null")) return Json();
    if (literal("true")) return Json(true);
    if (literal("false")) return Json(false);
    if (c == '-' || (c >= '0' && c <= '9')) {
      const char* begin = s_.c_str() + i_;
      char* end = nullptr;
      const double v = std::strtod(begin, &end);
      if (end == begin) fail("bad number");
      i_ += static_cast<std::size_t>(end - begin);
      return Json(v);
    }
    fail(std::string("unexpected character '") + c + "'");
  }
  std::string string() {
    ++i_;  // opening quote
    std::string out;
    while (true) {
      if (i_ >= s_.size()) fail("unterminated string");
      const char c = s_[i_++];
      if (c == '"') return out;
      if (c != '\\') {
        out += c;
        continue;
      }
      if (i_ >= s_.size()) fail("unterminated escape");
      const char e = s_[i_++];
      switch (e) {
        case '"':
        case '\\':
        case '/':
          out += e;
          break;
        case 'n':
          out += '\n';
          break;
        case 't':
          out += '\t';
          break;
        case 'r':
          out += '\r';
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'u': {
          if (i_ + 4 > s_.size()) fail("short \\u escape");
          unsigned code = 0;
          for (int k = 0; k < 4; ++k, ++i_) {
            const char h = s_[i_];
            if (!std::isxdigit(static_cast<unsigned char>(h))) fail("\\u escape with a non-hex digit");
            code = 16 * code + static_cast<unsigned>(h <= '9' ? h - '0' : (h | 0x20) - 'a' + 10);
          }
          if (code < 0x80) {
            out += static_cast<char>(code);
          } else if (code < 0x800) {
            out += static_cast<char>(0xc0 | (code >> 6));
            out += static_cast<char>(0x80 | (code & 0x3f));
          } else {
            out += static_cast<char>(0xe0 | (code >> 12));
            out += static_cast<char>(0x80 | ((code >> 6) & 0x3f));
            out += static_cast<char>(0x80 | (code & 0x3f));
          }
          break;
        }
        default:
          fail("bad escape");
      }
    }
  }
  Json array() {
    ++i_;
    Json a = Json::array();
    skip();
    if (i_ < s_.size() && s_[i_] == ']') {
      ++i_;
      return a;
    }
    while (true) {
      a.push(value());
      skip();
      if (i_ >= s_.size()) fail("unterminated array");
      if (s_[i_] == ',') {
        ++i_;
        continue;
      }
      if (s_[i_] == ']') {
        ++i_;
        return a;
      }
      fail("expected ',' or ']'");
    }
  }
  Json object() {
    ++i_;
    Json o = Json::object();
    skip();
    if (i_ < s_.size() && s_[i_] == '}') {
      ++i_;
      return o;
    }
    while (true) {
      skip();
      if (i_ >= s_.size() || s_[i_] != '"') fail("expected a key");
      const std::string key = string();
      skip();
      if (i_ >= s_.size() || s_[i_] != ':') fail("expected ':'");
      ++i_;
      o.set(key, value());
      skip();
      if (i_ >= s_.size()) fail("unterminated object");
      if (s_[i_] == ',') {
        ++i_;
        continue;
      }
      if (s_[i_] == '}') {
        ++i_;
        return o;
      }
      fail("expected ',' or '}'");
    }
  }

  static constexpr int kMaxDepth = 200;  ///< each level a recursion: deeper documents are refused
  int depth_ = 0;
  const std::string& s_;
  std::size_t i_ = 0;
};

}  // namespace

Json Json::parse(const std::string& text) { return Parser(text).document(); }

Json readJsonFile(const std::string& path) {
  const std::optional<std::string> text = readFile(path);
  if (!text) throw JsonError("cannot read " + path);
  try {
    return Json::parse(*text);
  } catch (const JsonError& e) {
    throw JsonError(path + ": " + e.what());
  }
}

void writeJsonFile(const std::string& path, const Json& value) {
  std::ofstream out(path);
  if (!out) throw JsonError("cannot write " + path);
  out << value.dump(2) << "\n";
  if (!out) throw JsonError("error writing " + path);
}

}  // namespace depowder::eval
