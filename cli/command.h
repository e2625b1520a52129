// Command registry of the `kinemetric` CLI. A command lives in one file cli/cmd_*.cpp and
// registers itself with KM_CLI_COMMAND; main dispatches on the first two words.
//
// Exit status (docs/formats.md §3): 0 success, 2 bad input (one-line reason on stderr naming file
// and line), 1 any other failure. Commands signal bad input by throwing km::InvalidInput; main maps
// exceptions to exit codes in one place.
#pragma once

#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace km::cli {

// Parsed arguments: positional words and --options (`--flag` or `--key value` / `--key=value`).
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  // "--json" -> "" ; "--machine" -> "m.json"
  bool json = false;

  bool Has(const std::string& opt) const { return options.count(opt) > 0; }
  std::optional<std::string> Get(const std::string& opt) const;
  double GetNumber(const std::string& opt, double fallback) const;
};

struct Command {
  std::string name;                        // e.g. "dbb analyze"
  std::string usage;                       // one line: arguments and options
  std::vector<std::string> value_options;  // options that take a value, e.g. "--machine"
  std::function<int(const Args&, std::ostream& out)> run;
};

std::map<std::string, Command>& Registry();

struct Registrar {
  explicit Registrar(Command c);
};

// Reads a whole file; throws km::InvalidInput naming the file when it cannot be read.
std::string ReadFileBytes(const std::string& path);

}  // namespace km::cli

#define KM_CLI_CONCAT2(a, b) a##b
#define KM_CLI_CONCAT(a, b) KM_CLI_CONCAT2(a, b)
#define KM_CLI_COMMAND(...)                                    \
  static ::km::cli::Registrar KM_CLI_CONCAT(km_cli_registrar_, \
                                            __LINE__)(::km::cli::Command{__VA_ARGS__})
