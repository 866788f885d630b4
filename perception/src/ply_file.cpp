// PLY point clouds by hand (no PCL): ascii and binary_little_endian, the vertex
// element's x y z of any numeric type; other elements (faces, lists) are skipped.
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "depowder/perception/point_file.hpp"

namespace depowder::perception {

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

class ParseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
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
      if (end == begin) throw ParseError("expected a number at byte " + std::to_string(pos_));
      pos_ += static_cast<std::size_t>(end - begin);
      return v;
    }
    const int size = typeSize(type);
    if (pos_ + static_cast<std::size_t>(size) > data_.size()) throw ParseError("the data section ends early");
    const char* p = data_.data() + pos_;
    pos_ += static_cast<std::size_t>(size);
    return decode(p, type);
  }

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
    pos = end + 1;
    return true;
  };
  std::string line;
  if (!nextLine(line) || line != "ply") throw ParseError("does not start with 'ply'");
  std::vector<Element> elements;
  bool have_format = false;
  while (true) {
    if (!nextLine(line)) throw ParseError("header has no end_header");
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
        throw ParseError("format '" + name + "' is not supported (ascii or binary_little_endian)");
      have_format = true;
    } else if (word == "element") {
      Element e;
      long long count = -1;
      s >> e.name >> count;
      if (!s || count < 0) throw ParseError("bad element line '" + line + "'");
      e.count = static_cast<std::size_t>(count);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw ParseError("property before any element");
      Property p;
      s >> p.type;
      if (p.type == "list") {
        p.list_size = "";
        s >> p.list_size >> p.type;
        if (typeSize(p.list_size) == 0) throw ParseError("bad list count type in '" + line + "'");
      }
      s >> p.name;
      if (!s || typeSize(p.type) == 0) throw ParseError("bad property line '" + line + "'");
      elements.back().properties.push_back(p);
    } else {
      throw ParseError("unknown header line '" + line + "'");
    }
  }
  if (!have_format) throw ParseError("header has no format line");
  data_start = pos;
  return elements;
}

}  // namespace

PointFile readPly(const std::string& path) {
  PointFile out;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    out.error = {FrameStatus::kUnreadable, path + ": cannot open the file"};
    return out;
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  try {
    Format format = Format::kAscii;
    std::size_t data_start = 0;
    const std::vector<Element> elements = parseHeader(text, format, data_start);
    Cursor cursor(text, data_start, format);
    bool found = false;
    for (const Element& e : elements) {
      int ix = -1, iy = -1, iz = -1;
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        if (!p.list_size.empty()) continue;
        if (p.name == "x") ix = static_cast<int>(k);
        if (p.name == "y") iy = static_cast<int>(k);
        if (p.name == "z") iz = static_cast<int>(k);
      }
      const bool vertex = e.name == "vertex";
      if (vertex && (ix < 0 || iy < 0 || iz < 0)) throw ParseError("the vertex element lacks x, y or z");
      if (vertex) out.points.reserve(e.count);
      std::vector<double> row(e.properties.size());
      for (std::size_t i = 0; i < e.count; ++i) {
        try {
          for (std::size_t k = 0; k < e.properties.size(); ++k) {
            const Property& p = e.properties[k];
            if (p.list_size.empty()) {
              row[k] = cursor.read(p.type);
            } else {
              const double n = cursor.read(p.list_size);
              if (n < 0 || n > 1e6) throw ParseError("list of impossible length " + std::to_string(n));
              for (int j = 0; j < static_cast<int>(n); ++j) cursor.read(p.type);
            }
          }
        } catch (const ParseError& err) {
          throw ParseError(std::string(err.what()) + " (in " + e.name + " " + std::to_string(i) + " of " +
                           std::to_string(e.count) + ")");
        }
        if (vertex) out.points.emplace_back(row[ix], row[iy], row[iz]);
      }
      if (vertex) {
        found = true;
        break;  // nothing after the vertices is needed
      }
    }
    if (!found) throw ParseError("has no vertex element");
  } catch (const ParseError& e) {
    out.points.clear();
    out.error = {FrameStatus::kUnreadable, path + ": not a readable PLY point cloud: " + e.what()};
    return out;
  }
  out.width = static_cast<int>(out.points.size());
  out.height = 1;
  return out;
}

}  // namespace depowder::perception
