// Atomic file output: write to a temporary file beside the target, then rename.
#pragma once
#include <string>

namespace flapstab {

// Writes `content` to `path` atomically (a failed run leaves no half-written file). Creates parent
// directories. Throws std::runtime_error naming the path on failure.
void write_file_atomic(const std::string& path, const std::string& content);

}  // namespace flapstab
