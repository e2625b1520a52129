#include "analysis/core/errors.h"

namespace km {
namespace {
std::string Compose(const std::string& file, std::size_t line, const std::string& field,
                    const std::string& reason) {
  std::string out;
  if (!file.empty()) out += file;
  if (line > 0) out += (out.empty() ? "line " : ":") + std::to_string(line);
  if (!field.empty()) out += (out.empty() ? "" : ": ") + std::string("field '") + field + "'";
  if (!out.empty()) out += ": ";
  return out + reason;
}
}  // namespace

InvalidInput::InvalidInput(std::string file, std::size_t line, std::string field,
                           std::string reason)
    : Error(Compose(file, line, field, reason)),
      file_(std::move(file)),
      line_(line),
      field_(std::move(field)),
      reason_(std::move(reason)) {}

}  // namespace km
