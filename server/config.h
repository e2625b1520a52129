// Server configuration: defaults, then the config file (JSON), then command-line options.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace km::server {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;
  std::string data_dir = "./var";
  std::string web_root;    // empty: <repo>/web/static found next to the binary
  bool demo_data = false;  // load demo data when the database is empty
  std::size_t max_upload_bytes = 32u << 20;
  int threads = 8;
  std::size_t queue_limit = 64;  // requests waiting for a thread; more are refused
  int read_timeout_s = 10;
  int write_timeout_s = 10;
  int keep_alive_max_count = 100;
  int keep_alive_timeout_s = 5;
  std::string modbus_config;  // Modbus TCP devices to acquire from (docs/modbus.md); empty: none
};

// Applies a JSON config file: keys listen ("HOST:PORT"), data_dir, web_root, demo_data,
// max_upload_bytes, threads, queue_limit, read_timeout_s, write_timeout_s,
// keep_alive_max_count, keep_alive_timeout_s, modbus_config. Unknown keys are an error (typos are
// not ignored). Numbers must be whole and within range (the command line too): threads 1–256,
// queue_limit and keep_alive_max_count 1–1 000 000, timeouts 1–3600 s, max_upload_bytes
// 1 B–4 GiB, port 0–65535 (0: any free port); data_dir must not be empty. Anything else is
// km::InvalidInput naming the option or key.
void ApplyConfigFile(ServerConfig& cfg, const std::string& path);
// Applies "HOST:PORT".
void ApplyListen(ServerConfig& cfg, const std::string& listen, const std::string& where);
// Parses argv (after the program name); throws km::InvalidInput on a bad option.
ServerConfig ParseServerArgs(const std::vector<std::string>& args);

}  // namespace km::server
