// What every reader of a file on disk needs first (its kind by extension, and its bytes), and
// the plainest point file.
#pragma once

#include <optional>
#include <string>

#include "depowder/geometry.hpp"

namespace depowder {

/// The extension of the path's file name, lower case, with its dot: ".stl"; "" if it has none.
std::string lowerExtension(const std::string& path);

/// The file's bytes, or nullopt if it cannot be opened.
std::optional<std::string> readFile(const std::string& path);

/// The points of a text file of "x y z" lines (blank lines and # comments skipped), times
/// `scale`: a CAD model given as surface points, such as the authors' pipe (cm). Throws
/// std::runtime_error naming the file, and the line of anything but three finite numbers.
Cloud readXyz(const std::string& path, double scale = 1.0);

}  // namespace depowder
