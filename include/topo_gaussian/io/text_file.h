// Whole text files, written atomically: the text goes to a temporary file beside the target, is
// flushed, and replaces the target by rename(2), so a crash or a full disk never leaves a truncated
// file where a good one was.
#pragma once

#include <string>

namespace topo_gaussian::io {

/// Writes `text` to `path` atomically. Throws TopoError naming the path when the directory is not
/// writable or the disk is full (the previous file, if any, is left as it was).
void writeTextFile(const std::string& path, const std::string& text);

/// The whole file (text or binary). Throws TopoError naming the path when it cannot be read or is larger than
/// `max_bytes`.
std::string readTextFile(const std::string& path, std::size_t max_bytes = 64u << 20);

}  // namespace topo_gaussian::io
