#include "server/base/finite_result.h"

#include <cmath>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

// Depth-first walk; `path` names the current value ("a.b[2]").
void Walk(const nlohmann::json& j, std::string& path, const std::string& file) {
  if (j.is_number_float()) {
    if (!std::isfinite(j.get<double>())) {
      throw InvalidInput(
          file, 0, path,
          "the values are too large to analyse: the result '" + path + "' is not a finite number");
    }
  } else if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      const std::size_t n = path.size();
      if (!path.empty()) path += '.';
      path += key;
      Walk(value, path, file);
      path.resize(n);
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      const std::size_t n = path.size();
      path += "[" + std::to_string(i) + "]";
      Walk(j[i], path, file);
      path.resize(n);
    }
  }
}

}  // namespace

void RequireFiniteResult(const nlohmann::json& result, const std::string& file) {
  std::string path;
  Walk(result, path, file);
}

}  // namespace km::server
