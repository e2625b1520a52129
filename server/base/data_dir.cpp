#include "server/base/data_dir.h"

#include <sys/stat.h>
#include <sys/types.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "analysis/core/errors.h"

namespace km::server {

void PrepareDataDir(const std::string& path) {
  namespace fs = std::filesystem;
  if (path.empty()) throw InvalidInput("", 0, "data_dir", "the data directory must not be empty");
  const fs::path dir(path);
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    // Missing parents as usual; the directory itself owner-only from its first moment.
    if (dir.has_parent_path() && !dir.parent_path().empty()) {
      fs::create_directories(dir.parent_path(), ec);
      if (ec) throw Error("data directory " + path + ": cannot create its parent: " + ec.message());
    }
    if (::mkdir(path.c_str(), 0700) != 0 && errno != EEXIST) {
      throw Error("data directory " + path + ": cannot create it: " + std::strerror(errno));
    }
  }
  if (!fs::is_directory(dir, ec)) throw Error("data directory " + path + " is not a directory");
  // Tightened whatever the umask or an older version left: owner only.
  if (::chmod(path.c_str(), 0700) != 0) {
    throw Error("data directory " + path +
                ": cannot make it owner-only (0700): " + std::strerror(errno));
  }
}

}  // namespace km::server
