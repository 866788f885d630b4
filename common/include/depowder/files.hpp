// What every reader of a file on disk needs first: its kind by extension, and its bytes.
#pragma once

#include <optional>
#include <string>

namespace depowder {

/// The extension of the path's file name, lower case, with its dot: ".stl"; "" if it has none.
std::string lowerExtension(const std::string& path);

/// The file's bytes, or nullopt if it cannot be opened.
std::optional<std::string> readFile(const std::string& path);

}  // namespace depowder
