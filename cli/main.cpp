// kinemetric — offline analysis of measurement files, simulation and discovery.
// Thin main: parse the command words, dispatch to the registry, map errors to exit codes.
#include <algorithm>
#include <exception>
#include <iostream>

#include "analysis/core/allocator.h"
#include "analysis/core/errors.h"
#include "cli/command.h"

namespace {

void PrintUsage(std::ostream& os) {
  os << "usage: kinemetric COMMAND [ARGS] [--json]\n\ncommands:\n";
  for (const auto& [name, cmd] : km::cli::Registry()) {
    os << "  kinemetric " << name << " " << cmd.usage << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  km::RetainFreedMemory();
  std::vector<std::string> words(argv + 1, argv + argc);
  if (words.empty() || words[0] == "--help" || words[0] == "-h" || words[0] == "help") {
    PrintUsage(words.empty() ? std::cerr : std::cout);
    return words.empty() ? 2 : 0;
  }
  const km::cli::Command* cmd = nullptr;
  std::size_t used = 0;
  for (std::size_t n = std::min<std::size_t>(2, words.size()); n >= 1 && !cmd; --n) {
    std::string name;
    for (std::size_t i = 0; i < n; ++i) name += (i ? " " : "") + words[i];
    const auto it = km::cli::Registry().find(name);
    if (it != km::cli::Registry().end()) {
      cmd = &it->second;
      used = n;
    }
  }
  if (!cmd) {
    std::cerr << "kinemetric: unknown command '" << words[0]
              << (words.size() > 1 ? " " + words[1] : std::string()) << "'\n";
    PrintUsage(std::cerr);
    return 2;
  }
  km::cli::Args args;
  try {
    for (std::size_t i = used; i < words.size(); ++i) {
      const auto& w = words[i];
      if (w.rfind("--", 0) == 0 && w.size() > 2) {
        const auto eq = w.find('=');
        if (eq != std::string::npos) {
          args.options[w.substr(0, eq)] = w.substr(eq + 1);
          continue;
        }
        const bool takes_value = std::find(cmd->value_options.begin(), cmd->value_options.end(),
                                           w) != cmd->value_options.end();
        if (takes_value) {
          if (i + 1 >= words.size()) {
            throw km::InvalidInput("", 0, w, "option needs a value");
          }
          args.options[w] = words[++i];
        } else {
          args.options[w] = "";
        }
      } else {
        args.positional.push_back(w);
      }
    }
    args.json = args.Has("--json");
    if (args.Has("--help")) {
      std::cout << "usage: kinemetric " << cmd->name << " " << cmd->usage << "\n";
      return 0;
    }
    return cmd->run(args, std::cout);
  } catch (const km::InvalidInput& e) {
    std::cerr << "kinemetric " << cmd->name << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "kinemetric " << cmd->name << ": error: " << e.what() << "\n";
    return 1;
  }
}
