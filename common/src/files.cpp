#include "depowder/files.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace depowder {

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::optional<std::string> readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return std::move(bytes).str();
}

Cloud readXyz(const std::string& path, double scale) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("points '" + path + "': cannot open the file");
  Cloud out;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream s(line);
    Point p;
    std::string rest;
    if (!(s >> p.x() >> p.y() >> p.z()) || !p.allFinite() || (s >> rest))
      throw std::runtime_error("points '" + path + "', line " + std::to_string(number) + ": not three finite numbers");
    out.push_back(scale * p);
  }
  if (out.empty()) throw std::runtime_error("points '" + path + "': no point");
  return out;
}

}  // namespace depowder
