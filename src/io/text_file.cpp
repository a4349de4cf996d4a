#include "topo_gaussian/io/text_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

void writeTextFile(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw TopoError(path, "cannot be written (" + std::string(std::strerror(errno)) + ")",
                      "check that the directory exists and is writable");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw TopoError(path, "could not be written completely (disk full?)", "free space and write it again");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    throw TopoError(path, "cannot be replaced (" + why + ")", "check the permissions of the file and its directory");
  }
}

std::string readTextFile(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw TopoError(path, "is not a regular file", "give the path of an existing file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw TopoError(path, "cannot be read (" + ec.message() + ")", "check the path and its permissions");
  if (size > max_bytes)
    throw TopoError(path,
                    "is " + std::to_string(size) + " bytes, more than the " + std::to_string(max_bytes) +
                        " a text file of ours can be",
                    "give the right file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw TopoError(path, "cannot be opened", "check its permissions");
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

}  // namespace topo_gaussian::io
