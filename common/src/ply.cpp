#include "depowder/ply.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace depowder {
namespace {

enum class Format { kAscii, kBinaryLittleEndian };

struct Property {
  std::string name;
  std::string type;       ///< scalar type, or the item type of a list
  std::string list_size;  ///< list count type; empty for a scalar
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

int typeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// Reads one value of the file's data section, ascii or binary, with bounds checks.
class Cursor {
 public:
  Cursor(const std::string& data, std::size_t pos, Format format) : data_(data), pos_(pos), format_(format) {}

  double read(const std::string& type) {
    if (format_ == Format::kAscii) {
      const char* begin = data_.c_str() + pos_;
      char* end = nullptr;
      const double v = std::strtod(begin, &end);
      if (end == begin) throw PlyError("expected a number at byte " + std::to_string(pos_));
      pos_ += static_cast<std::size_t>(end - begin);
      return v;
    }
    const int size = typeSize(type);
    if (pos_ + static_cast<std::size_t>(size) > data_.size()) throw PlyError("the data section ends early");
    const char* p = data_.data() + pos_;
    pos_ += static_cast<std::size_t>(size);
    return decode(p, type);
  }

  /// A count or an index: a whole number in [0, max].
  std::size_t readIndex(const std::string& type, double max, const char* what) {
    const double v = read(type);
    if (!(v >= 0 && v <= max && v == std::floor(v))) throw PlyError(std::string(what) + " " + std::to_string(v));
    return static_cast<std::size_t>(v);
  }

  std::size_t left() const { return data_.size() - pos_; }

 private:
  template <class T>
  static double as(const char* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));  // little-endian host assumed (x86, arm64)
    return static_cast<double>(v);
  }
  static double decode(const char* p, const std::string& t) {
    if (t == "char" || t == "int8") return as<std::int8_t>(p);
    if (t == "uchar" || t == "uint8") return as<std::uint8_t>(p);
    if (t == "short" || t == "int16") return as<std::int16_t>(p);
    if (t == "ushort" || t == "uint16") return as<std::uint16_t>(p);
    if (t == "int" || t == "int32") return as<std::int32_t>(p);
    if (t == "uint" || t == "uint32") return as<std::uint32_t>(p);
    if (t == "float" || t == "float32") return as<float>(p);
    return as<double>(p);
  }

  const std::string& data_;
  std::size_t pos_;
  Format format_;
};

std::vector<Element> parseHeader(const std::string& text, Format& format, std::size_t& data_start) {
  std::size_t pos = 0;
  auto nextLine = [&](std::string& line) {
    if (pos >= text.size()) return false;
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(end + 1, text.size());  // a last line may lack its newline
    return true;
  };
  std::string line;
  if (!nextLine(line) || line != "ply") throw PlyError("does not start with 'ply'");
  std::vector<Element> elements;
  bool have_format = false;
  while (true) {
    if (!nextLine(line)) throw PlyError("header has no end_header");
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (word == "end_header") break;
    if (word == "comment" || word == "obj_info" || word.empty()) continue;
    if (word == "format") {
      std::string name;
      s >> name;
      if (name == "ascii")
        format = Format::kAscii;
      else if (name == "binary_little_endian")
        format = Format::kBinaryLittleEndian;
      else
        throw PlyError("format '" + name + "' is not supported (ascii or binary_little_endian)");
      have_format = true;
    } else if (word == "element") {
      Element e;
      long long count = -1;
      s >> e.name >> count;
      if (!s || count < 0) throw PlyError("bad element line '" + line + "'");
      e.count = static_cast<std::size_t>(count);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw PlyError("property before any element");
      Property p;
      s >> p.type;
      if (p.type == "list") {
        s >> p.list_size >> p.type;
        if (typeSize(p.list_size) == 0) throw PlyError("bad list count type in '" + line + "'");
      }
      s >> p.name;
      if (!s || typeSize(p.type) == 0) throw PlyError("bad property line '" + line + "'");
      elements.back().properties.push_back(p);
    } else {
      throw PlyError("unknown header line '" + line + "'");
    }
  }
  if (!have_format) throw PlyError("header has no format line");
  data_start = pos;
  return elements;
}

bool isFaceIndices(const Element& e, const Property& p) {
  return e.name == "face" && !p.list_size.empty() && (p.name == "vertex_indices" || p.name == "vertex_index");
}

// A face of n vertex indices, as a fan of triangles into `out` (its vertices read already).
void readFace(Cursor& cursor, std::size_t n, const std::string& type, PlyData& out) {
  if (n < 3) throw PlyError("a face with fewer than 3 vertices");
  std::vector<int> face(n);
  for (int& index : face) {
    index = static_cast<int>(cursor.readIndex(type, INT_MAX, "a vertex index of"));
    if (index >= static_cast<int>(out.vertices.size()))
      throw PlyError("a vertex index out of range, " + std::to_string(index));
  }
  for (std::size_t j = 1; j + 1 < n; ++j) out.triangles.emplace_back(face[0], face[j], face[j + 1]);
}

}  // namespace

PlyData parsePly(const std::string& bytes, bool faces) {
  Format format = Format::kAscii;
  std::size_t data_start = 0;
  const std::vector<Element> elements = parseHeader(bytes, format, data_start);
  Cursor cursor(bytes, data_start, format);
  PlyData out;
  bool have_vertices = false;
  for (const Element& e : elements) {
    if (e.properties.empty()) continue;  // its items take no bytes
    int ix = -1, iy = -1, iz = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const Property& p = e.properties[k];
      if (!p.list_size.empty()) continue;
      if (p.name == "x") ix = static_cast<int>(k);
      if (p.name == "y") iy = static_cast<int>(k);
      if (p.name == "z") iz = static_cast<int>(k);
    }
    const bool vertex = e.name == "vertex";
    if (vertex && (ix < 0 || iy < 0 || iz < 0)) throw PlyError("the vertex element lacks x, y or z");
    if (vertex) out.vertices.reserve(std::min(e.count, cursor.left()));  // an item takes a byte at least
    std::vector<double> row(e.properties.size());
    for (std::size_t i = 0; i < e.count; ++i) {
      try {
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const Property& p = e.properties[k];
          if (p.list_size.empty()) {
            row[k] = cursor.read(p.type);
            continue;
          }
          const std::size_t n = cursor.readIndex(p.list_size, static_cast<double>(cursor.left()), "a list of length");
          if (faces && isFaceIndices(e, p))
            readFace(cursor, n, p.type, out);
          else
            for (std::size_t j = 0; j < n; ++j) cursor.read(p.type);
        }
      } catch (const PlyError& err) {
        throw PlyError(std::string(err.what()) + " (in " + e.name + " " + std::to_string(i) + " of " +
                       std::to_string(e.count) + ")");
      }
      if (vertex) out.vertices.emplace_back(row[ix], row[iy], row[iz]);
    }
    have_vertices = have_vertices || vertex;
    if (have_vertices && !faces) break;  // nothing after the vertices is needed
  }
  if (!have_vertices) throw PlyError("has no vertex element");
  return out;
}

}  // namespace depowder
