#include "server/config.h"

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"

namespace km::server {

void ApplyListen(ServerConfig& cfg, const std::string& listen, const std::string& where) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    throw InvalidInput(where, 0, "listen", "expected HOST:PORT, got '" + listen + "'");
  }
  int port = 0;
  try {
    std::size_t used = 0;
    port = std::stoi(listen.substr(colon + 1), &used);
    if (used != listen.size() - colon - 1) throw std::invalid_argument("junk");
  } catch (const std::exception&) {
    throw InvalidInput(where, 0, "listen", "bad port in '" + listen + "'");
  }
  if (port < 0 || port > 65535) throw InvalidInput(where, 0, "listen", "port out of range");
  cfg.host = listen.substr(0, colon);
  if (cfg.host.size() > 2 && cfg.host.front() == '[' && cfg.host.back() == ']') {
    cfg.host = cfg.host.substr(1, cfg.host.size() - 2);
  }
  cfg.port = port;
}

void ApplyConfigFile(ServerConfig& cfg, const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InvalidInput(path, 0, "", "cannot open the config file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidInput(path, 0, "", std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) throw InvalidInput(path, 0, "", "the config file must be a JSON object");
  for (const auto& [key, v] : j.items()) {
    try {
      if (key == "listen") {
        ApplyListen(cfg, v.get<std::string>(), path);
      } else if (key == "data_dir") {
        cfg.data_dir = v.get<std::string>();
      } else if (key == "web_root") {
        cfg.web_root = v.get<std::string>();
      } else if (key == "demo_data") {
        cfg.demo_data = v.get<bool>();
      } else if (key == "max_upload_bytes") {
        cfg.max_upload_bytes = v.get<std::size_t>();
      } else if (key == "threads") {
        cfg.threads = v.get<int>();
      } else if (key == "queue_limit") {
        cfg.queue_limit = v.get<std::size_t>();
      } else if (key == "read_timeout_s") {
        cfg.read_timeout_s = v.get<int>();
      } else if (key == "write_timeout_s") {
        cfg.write_timeout_s = v.get<int>();
      } else if (key == "keep_alive_max_count") {
        cfg.keep_alive_max_count = v.get<int>();
      } else if (key == "keep_alive_timeout_s") {
        cfg.keep_alive_timeout_s = v.get<int>();
      } else if (key == "modbus_config") {
        cfg.modbus_config = v.get<std::string>();
      } else {
        throw InvalidInput(path, 0, key, "unknown configuration key");
      }
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(path, 0, key, std::string("wrong type: ") + e.what());
    }
  }
  if (cfg.threads < 1 || cfg.threads > 256) throw InvalidInput(path, 0, "threads", "1 to 256");
}

ServerConfig ParseServerArgs(const std::vector<std::string>& args) {
  ServerConfig cfg;
  // The config file first, so that command-line options override it.
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == "--config") ApplyConfigFile(cfg, args[i + 1]);
  }
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw InvalidInput("", 0, a, "option needs a value");
      return args[++i];
    };
    auto number = [&](const std::string& v) {
      try {
        return std::stoi(v);
      } catch (const std::exception&) {
        throw InvalidInput("", 0, a, "'" + v + "' is not a whole number");
      }
    };
    if (a == "--listen") {
      ApplyListen(cfg, value(), "--listen");
    } else if (a == "--data-dir") {
      cfg.data_dir = value();
    } else if (a == "--config") {
      value();
    } else if (a == "--web-root") {
      cfg.web_root = value();
    } else if (a == "--modbus-config") {
      cfg.modbus_config = value();
    } else if (a == "--demo-data") {
      cfg.demo_data = true;
    } else if (a == "--threads") {
      cfg.threads = number(value());
    } else if (a == "--max-upload-bytes") {
      cfg.max_upload_bytes = static_cast<std::size_t>(number(value()));
    } else {
      throw InvalidInput("", 0, a, "unknown option");
    }
  }
  return cfg;
}

}  // namespace km::server
