// A small JSON value: enough to write the evaluation's results, read them back (report --from)
// and check their shape in tests. Objects keep their keys in insertion order; NaN and
// infinities are written as null (JSON has neither).
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace depowder::eval {

class JsonError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Json {
 public:
  enum class Type { kNull, kBool, kNumber, kString, kArray, kObject };

  Json() = default;
  Json(std::nullptr_t) {}
  Json(bool b) : type_(Type::kBool), bool_(b) {}
  Json(double v) : type_(Type::kNumber), number_(v) {}
  Json(int v) : type_(Type::kNumber), number_(v) {}
  Json(long v) : type_(Type::kNumber), number_(static_cast<double>(v)) {}
  Json(long long v) : type_(Type::kNumber), number_(static_cast<double>(v)) {}
  Json(unsigned v) : type_(Type::kNumber), number_(v) {}
  Json(unsigned long v) : type_(Type::kNumber), number_(static_cast<double>(v)) {}
  Json(std::string s) : type_(Type::kString), string_(std::move(s)) {}
  Json(const char* s) : type_(Type::kString), string_(s) {}
  static Json array() { return Json(Type::kArray); }
  static Json object() { return Json(Type::kObject); }
  template <typename T>
  static Json arrayOf(const std::vector<T>& values) {
    Json a = array();
    for (const T& v : values) a.push(Json(v));
    return a;
  }

  bool isNull() const { return type_ == Type::kNull; }
  bool isNumber() const { return type_ == Type::kNumber; }

  /// Appends to an array.
  Json& push(Json value);
  /// Sets a key of an object (replaces an existing one).
  Json& set(const std::string& key, Json value);

  bool has(const std::string& key) const;
  /// The member `key`; throws JsonError naming the key if absent or this is not an object.
  const Json& at(const std::string& key) const;
  const Json& at(std::size_t i) const;
  std::size_t size() const;  ///< elements of an array or members of an object
  const std::vector<Json>& elements() const { return array_; }

  bool boolean() const;
  double number() const;  ///< null reads as NaN (how NaN was written)
  const std::string& string() const;

  std::string dump(int indent = 2) const;
  /// Throws JsonError with the offset of the first problem.
  static Json parse(const std::string& text);

 private:
  explicit Json(Type t) : type_(t) {}
  void dumpTo(std::string& out, int indent, int depth) const;

  Type type_ = Type::kNull;
  bool bool_ = false;
  double number_ = 0;
  std::string string_;
  std::vector<Json> array_;
  std::vector<std::pair<std::string, Json>> object_;
};

/// Reads / writes a whole file; throw JsonError naming the file.
Json readJsonFile(const std::string& path);
void writeJsonFile(const std::string& path, const Json& value);

}  // namespace depowder::eval
