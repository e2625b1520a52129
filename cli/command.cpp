#include "cli/command.h"

#include <fstream>
#include <sstream>

#include "analysis/core/errors.h"
#include "ingest/text_format.h"

namespace km::cli {

std::optional<std::string> Args::Get(const std::string& opt) const {
  const auto it = options.find(opt);
  if (it == options.end()) return std::nullopt;
  return it->second;
}

double Args::GetNumber(const std::string& opt, double fallback) const {
  const auto v = Get(opt);
  if (!v) return fallback;
  const auto n = ingest::ParseNumber(*v);
  if (!n) throw InvalidInput("", 0, opt, "'" + *v + "' is not a number");
  return *n;
}

std::map<std::string, Command>& Registry() {
  static std::map<std::string, Command> registry;
  return registry;
}

Registrar::Registrar(Command c) {
  auto name = c.name;
  Registry().emplace(std::move(name), std::move(c));
}

std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidInput(path, 0, "", "cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InvalidInput(path, 0, "", "cannot read the file");
  return ss.str();
}

}  // namespace km::cli
