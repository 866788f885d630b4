// PCD via PCL's reader: the only file of the project that includes PCL (it compiles
// slowly). PCLPointCloud2 is read untyped, so every field layout and every DATA kind
// (ascii, binary, binary_compressed) works without instantiating point templates.
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "depowder/perception/point_file.hpp"

namespace depowder::perception {

namespace {

double fieldValue(const std::uint8_t* p, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::FLOAT32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::FLOAT64: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
    default:
      return std::numeric_limits<double>::quiet_NaN();
  }
}

// PCL 1.13's reader crashes on some malformed headers (an empty file or one without
// FIELDS segfaults in getFieldsList, PCL issue #5854, and so does a header that a line of
// spaces ends early; a TYPE other than I, U or F asks for terabytes), so the header is
// checked here first, read the way PCL reads it.
// Returns "" if PCL can be trusted with the file, else what is wrong with it.
std::string checkHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "cannot open the file";
  in.seekg(0, std::ios::end);
  const auto file_size = static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg()));
  in.seekg(0);
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<std::string> types;
  long long width = -1, height = 1, points = -1;
  std::string line, data;
  for (int n = 0; n < 64 && data.empty() && std::getline(in, line); ++n) {
    if (line.empty()) continue;
    std::istringstream s(line);
    std::string key;
    s >> key;
    // PCL ends its header at a line of only spaces (or a lone CR), and reads on without FIELDS.
    if (key.empty()) return "a blank line with spaces inside the header";
    if (key[0] == '#') continue;
    if (line.back() == '\r') line.pop_back();
    std::string word;
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS") {
      while (s >> word) fields.push_back(word);
    } else if (key == "SIZE") {
      int v;
      while (s >> v) sizes.push_back(v);
    } else if (key == "TYPE") {
      while (s >> word) types.push_back(word);
    } else if (key == "COUNT") {
      int v;
      while (s >> v) counts.push_back(v);
    } else if (key == "WIDTH") {
      s >> width;
    } else if (key == "HEIGHT") {
      s >> height;
    } else if (key == "POINTS") {
      s >> points;
    } else if (key == "DATA") {
      s >> data;
      if (data.empty()) data = "?";
    } else {
      return "not a PCD file (unexpected header line '" + line.substr(0, 40) + "')";
    }
  }
  if (data.empty()) return "not a PCD file (no DATA line in the header)";
  if (data != "ascii" && data != "binary" && data != "binary_compressed")
    return "unknown DATA kind '" + data + "' (ascii, binary or binary_compressed)";
  if (fields.empty()) return "header has no FIELDS";
  if (sizes.size() != fields.size() || types.size() != fields.size())
    return "header's SIZE / TYPE do not match its FIELDS";
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (counts.size() != fields.size()) return "header's COUNT does not match its FIELDS";
  std::size_t point_size = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (sizes[i] != 1 && sizes[i] != 2 && sizes[i] != 4 && sizes[i] != 8) return "header has an invalid SIZE";
    // PCL takes any other TYPE for a field of no known type and then reads the data as garbage.
    if (types[i] != "I" && types[i] != "U" && types[i] != "F") return "header has an invalid TYPE (I, U or F)";
    if (types[i] == "F" && sizes[i] < 4) return "header has a float (TYPE F) of SIZE " + std::to_string(sizes[i]);
    if (counts[i] < 1) return "header has an invalid COUNT";
    point_size += static_cast<std::size_t>(sizes[i]) * static_cast<std::size_t>(counts[i]);
  }
  if (width < 1 || height < 1) return "holds no point (WIDTH or HEIGHT missing or zero)";
  constexpr long long kMaxSide = 0xffffffffLL;  // PCL keeps WIDTH and HEIGHT as 32-bit numbers
  if (width > kMaxSide || height > kMaxSide) return "WIDTH or HEIGHT is beyond 2^32 - 1";
  const auto cells = static_cast<unsigned long long>(width) * static_cast<unsigned long long>(height);
  if (points >= 0 && static_cast<unsigned long long>(points) != cells) return "POINTS disagrees with WIDTH x HEIGHT";
  std::size_t values_per_point = 0;  // an ascii value takes a byte at least
  for (const int c : counts) values_per_point += static_cast<std::size_t>(c);
  unsigned long long bytes = 0, values = 0;
  const bool too_big =
      __builtin_mul_overflow(cells, point_size, &bytes) || __builtin_mul_overflow(cells, values_per_point, &values);
  const std::size_t header_end = static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg()));
  // PCL reads on past DATA while lines start with a header keyword, so a data line that does
  // ("COLUMNS" alone: no fields, then a read through a wild pointer) would change the header.
  std::string first;  // the first data line, as PCL sees it (trimmed, comments skipped)
  while (first.empty() && std::getline(in, line))
    if (const auto b = line.find_first_not_of(" \t\r"); b != std::string::npos && line[b] != '#')
      first = line.substr(b, 40);
  for (const char* key :
       {"VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"})
    if (first.rfind(key, 0) == 0) return "a header line after DATA ('" + first + "')";
  const std::size_t data_size = file_size - std::min(file_size, header_end);
  if (data == "binary" && (too_big || data_size < bytes))
    return "binary data is shorter than its header says (" + std::to_string(data_size) + " bytes for " +
           std::to_string(cells) + " points of " + std::to_string(point_size) + ")";
  if (data == "ascii" && (too_big || data_size < values))
    return "ascii data is shorter than its header says (" + std::to_string(data_size) + " bytes for " +
           std::to_string(cells) + " points of " + std::to_string(values_per_point) + " values)";
  if (data == "binary_compressed" && file_size < header_end + 8) return "compressed data is missing";
  return "";
}

}  // namespace

PointFile readPcd(const std::string& path) {
  PointFile out;
  auto unreadable = [&](const std::string& why) {
    out.points.clear();
    out.error = {FrameStatus::kUnreadable, path + ": " + why};
    return out;
  };
  if (const std::string why = checkHeader(path); !why.empty()) return unreadable(why);
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int rc = -1;
  try {
    // PCL prints its own reason at error level; ours below names the file.
    rc = pcl::PCDReader().read(path, blob, origin, orientation, version);
  } catch (const std::exception& e) {
    return unreadable(std::string("not a readable PCD file: ") + e.what());
  }
  if (rc < 0) return unreadable("not a readable PCD file (bad header, truncated data or corrupt compression)");
  int offset[3] = {-1, -1, -1};
  std::uint8_t type[3] = {0, 0, 0};
  const char* names[3] = {"x", "y", "z"};
  for (const pcl::PCLPointField& f : blob.fields)
    for (int k = 0; k < 3; ++k)
      if (f.name == names[k]) {
        offset[k] = static_cast<int>(f.offset);
        type[k] = f.datatype;
      }
  for (int k = 0; k < 3; ++k) {
    if (offset[k] < 0) return unreadable(std::string("has no '") + names[k] + "' field");
    if (type[k] != pcl::PCLPointField::FLOAT32 && type[k] != pcl::PCLPointField::FLOAT64)
      return unreadable(std::string("field '") + names[k] + "' is not a float (F 4 or F 8)");
    const int size = type[k] == pcl::PCLPointField::FLOAT32 ? 4 : 8;
    if (offset[k] + size > static_cast<int>(blob.point_step)) return unreadable("field layout exceeds point size");
  }
  if (blob.is_bigendian) return unreadable("big-endian data is not supported");
  const std::size_t w = blob.width, h = blob.height;
  if (w == 0 || h == 0) return unreadable("holds no point");
  if (blob.row_step < w * blob.point_step || blob.data.size() < h * blob.row_step)
    return unreadable("data is shorter than its header says");
  out.points.reserve(w * h);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c) {
      const std::uint8_t* p = blob.data.data() + r * blob.row_step + c * blob.point_step;
      out.points.emplace_back(fieldValue(p + offset[0], type[0]), fieldValue(p + offset[1], type[1]),
                              fieldValue(p + offset[2], type[2]));
    }
  out.width = static_cast<int>(w);
  out.height = static_cast<int>(h);
  return out;
}

}  // namespace depowder::perception
