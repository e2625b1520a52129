// Modbus TCP acquisition of one device (docs/modbus.md): one thread, one libmodbus context
// created and freed in that thread, polling the device's read blocks (modbus_decode.h) on a
// steady-clock schedule.
//
// Schedule: tick k is due at start + k·poll_interval (start = when the thread began). Every
// sample taken at tick k carries counter k, so a tick that was not sampled (device down,
// timeout, exception, overrun) is a jump in the counter — a gap — and is counted in
// skipped_ticks. If the thread is late by a whole interval or more it jumps to the latest due
// tick (never a burst of catch-up reads). polls_ok + skipped_ticks == next_counter.
// t_us is system-clock µs at the middle of the block's request/response exchange, the same
// for all channels of the block.
//
// Errors are never fatal: a Modbus exception response counts `exceptions` (stays connected);
// a response timeout counts `timeouts` (flush, stay connected; 3 consecutive timeouts or
// protocol errors → reconnect); a connection error (refused, reset, broken pipe, …) counts
// `connection_errors`, closes the connection and reconnects at once, with an exponential
// backoff (reconnect.initial_ms doubling up to reconnect.max_ms) between failed attempts. A
// connection lost before the device answered anything (accepts, then resets or stays silent)
// also waits out the backoff before the next attempt; any answer resets the delay.
// `reconnects` counts successful connections after the first. Stop() interrupts a backoff or
// a wait for the next tick at once; a request in flight ends within response_timeout_ms.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "ingest/modbus/modbus_config.h"
#include "ingest/stream/stream_record.h"

namespace km::ingest::modbus {

struct DeviceStatus {
  std::string name;
  std::string state = "stopped";  // "connecting", "connected", "backoff", "stopped"
  bool connected = false;
  std::int64_t last_sample_t_us = 0;  // t_us of the last delivered block (0: none yet)
  std::uint64_t polls_ok = 0;         // ticks at which every block was read
  std::uint64_t exceptions = 0;       // Modbus exception responses
  std::uint64_t timeouts = 0;         // response timeouts
  std::uint64_t protocol_errors = 0;  // malformed/mismatched responses
  std::uint64_t connection_errors = 0;
  std::uint64_t reconnects = 0;
  std::uint64_t skipped_ticks = 0;  // ticks at which at least one block was not read
  // Of skipped_ticks, those passed over while connected because the previous poll ended, or
  // the thread woke, a whole interval late (overrun: slow responses, CPU starvation).
  std::uint64_t late_ticks = 0;
  std::uint64_t samples_delivered = 0;
  std::string last_error;
  std::uint64_t next_counter = 0;  // index of the next tick
};

nlohmann::json ToJson(const DeviceStatus& s);

class ModbusDevice {
 public:
  // `sink` must outlive the device; Deliver is called from the device thread.
  ModbusDevice(DeviceConfig config, SampleSink& sink);
  ~ModbusDevice();  // Stop()
  ModbusDevice(const ModbusDevice&) = delete;
  ModbusDevice& operator=(const ModbusDevice&) = delete;

  void Start();  // starts the thread (no effect if running); a restart resets counters and status
  void Stop();   // asks the thread to end and joins it
  DeviceStatus Status() const;
  const DeviceConfig& config() const { return config_; }

 private:
  // The poll loop (modbus_device.cpp) in named steps: connect (with backoff), wait for the
  // next tick, read every block, count the tick.
  struct PollState;
  enum class ConnectOutcome { kConnected, kRetry, kStopping };
  void Run();
  void RunLoop();
  ConnectOutcome Connect(PollState& s);
  bool WaitForTick(PollState& s, std::uint64_t& jumped);  // false if stopping
  bool PollBlocks(PollState& s);                          // true when every block was read
  void DeliverBlock(PollState& s, const ReadBlock& b, std::int64_t t_us);
  bool ReadFailed(PollState& s, const ReadBlock& b, int n, int err);  // true: end this tick
  void Disconnect(PollState& s);
  void EndTick(PollState& s, std::uint64_t jumped, bool all_ok);
  void SetError(std::uint64_t DeviceStatus::*counter, std::string message);
  void SetState(const char* state, bool connected);
  // Waits until `deadline` or Stop(); returns false if stopping.
  bool WaitUntil(std::chrono::steady_clock::time_point deadline);

  const DeviceConfig config_;
  const std::vector<ReadBlock> blocks_;
  SampleSink& sink_;

  std::thread thread_;
  std::mutex wait_mu_;
  std::condition_variable wait_cv_;
  bool stop_ = false;  // guarded by wait_mu_

  mutable std::mutex status_mu_;
  DeviceStatus status_;
};

}  // namespace km::ingest::modbus
