#include "ingest/modbus_device.h"

#include <modbus/modbus.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <exception>
#include <memory>
#include <utility>

namespace km::ingest::modbus {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kMaxConsecutiveBadResponses = 3;

enum class ErrorKind { kException, kTimeout, kProtocol, kConnection };

ErrorKind Classify(int err) {
  if (err >= EMBXILFUN && err <= EMBXGTAR) return ErrorKind::kException;
  if (err == ETIMEDOUT) return ErrorKind::kTimeout;
  if (err == EMBBADCRC || err == EMBBADDATA || err == EMBBADEXC || err == EMBUNKEXC ||
      err == EMBMDATA || err == EMBBADSLAVE) {
    return ErrorKind::kProtocol;
  }
  return ErrorKind::kConnection;
}

std::int64_t SystemMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct ContextDeleter {
  void operator()(modbus_t* ctx) const {
    modbus_close(ctx);
    modbus_free(ctx);
  }
};
using Context = std::unique_ptr<modbus_t, ContextDeleter>;

}  // namespace

nlohmann::json ToJson(const DeviceStatus& s) {
  return {{"name", s.name},
          {"state", s.state},
          {"connected", s.connected},
          {"last_sample_t_us", s.last_sample_t_us},
          {"polls_ok", s.polls_ok},
          {"exceptions", s.exceptions},
          {"timeouts", s.timeouts},
          {"protocol_errors", s.protocol_errors},
          {"connection_errors", s.connection_errors},
          {"reconnects", s.reconnects},
          {"skipped_ticks", s.skipped_ticks},
          {"late_ticks", s.late_ticks},
          {"samples_delivered", s.samples_delivered},
          {"last_error", s.last_error},
          {"next_counter", s.next_counter}};
}

ModbusDevice::ModbusDevice(DeviceConfig config, SampleSink& sink)
    : config_(std::move(config)), blocks_(PlanDeviceBlocks(config_)), sink_(sink) {
  status_.name = config_.name;
}

ModbusDevice::~ModbusDevice() {
  Stop();
}

void ModbusDevice::Start() {
  if (thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(wait_mu_);
    stop_ = false;
  }
  {
    // A new run: its sample counters start at 0 again, and so do the counts.
    std::lock_guard<std::mutex> lock(status_mu_);
    status_ = DeviceStatus{};
    status_.name = config_.name;
    status_.state = "connecting";
  }
  thread_ = std::thread([this] { Run(); });
}

void ModbusDevice::Stop() {
  {
    std::lock_guard<std::mutex> lock(wait_mu_);
    stop_ = true;
  }
  wait_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard<std::mutex> lock(status_mu_);
  status_.state = "stopped";
  status_.connected = false;
}

DeviceStatus ModbusDevice::Status() const {
  std::lock_guard<std::mutex> lock(status_mu_);
  return status_;
}

bool ModbusDevice::WaitUntil(Clock::time_point deadline) {
  std::unique_lock<std::mutex> lock(wait_mu_);
  wait_cv_.wait_until(lock, deadline, [this] { return stop_; });
  return !stop_;
}

void ModbusDevice::Run() {
  // Nothing escapes the thread: an unexpected exception (e.g. std::bad_alloc) ends the
  // acquisition with the reason in last_error.
  try {
    RunLoop();
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(status_mu_);
    status_.last_error = std::string("acquisition stopped: ") + e.what();
  } catch (...) {
    std::lock_guard<std::mutex> lock(status_mu_);
    status_.last_error = "acquisition stopped: unknown error";
  }
  std::lock_guard<std::mutex> lock(status_mu_);
  status_.state = "stopped";
  status_.connected = false;
}

void ModbusDevice::RunLoop() {
  const auto interval = std::chrono::milliseconds(config_.poll_interval_ms);
  const auto start = Clock::now();
  const std::uint32_t to_s = static_cast<std::uint32_t>(config_.response_timeout_ms / 1000);
  const std::uint32_t to_us = static_cast<std::uint32_t>(config_.response_timeout_ms % 1000) * 1000;

  auto set_error = [this](std::uint64_t DeviceStatus::*counter, std::string message) {
    std::lock_guard<std::mutex> lock(status_mu_);
    ++(status_.*counter);
    status_.last_error = std::move(message);
  };
  auto set_state = [this](const char* state, bool connected) {
    std::lock_guard<std::mutex> lock(status_mu_);
    status_.state = state;
    status_.connected = connected;
  };

  // One libmodbus context for this device, created and freed in this thread.
  Context ctx(modbus_new_tcp_pi(config_.host.c_str(), std::to_string(config_.port).c_str()));
  if (!ctx) {
    set_error(&DeviceStatus::connection_errors,
              std::string("cannot create a Modbus context: ") + modbus_strerror(errno));
    return;
  }
  modbus_set_slave(ctx.get(), config_.unit_id);
  modbus_set_response_timeout(ctx.get(), to_s, to_us);
  modbus_set_byte_timeout(ctx.get(), to_s, to_us);
  modbus_set_error_recovery(ctx.get(), MODBUS_ERROR_RECOVERY_NONE);

  std::vector<std::uint16_t> regs(kMaxRegistersPerRead);
  std::vector<StreamSample> samples;
  std::uint64_t k = 0;  // next tick
  bool connected = false;
  bool ever_connected = false;
  int backoff_ms = config_.reconnect.initial_ms;
  int bad_in_a_row = 0;
  // A connection that was lost before the device answered anything (it accepts and then
  // resets, or never answers) is re-opened only after the backoff delay, like a refused one.
  bool answered_since_connect = false;
  bool backoff_first = false;
  bool fresh_connection = false;  // connected since the previous tick

  while (true) {
    {
      std::lock_guard<std::mutex> lock(wait_mu_);
      if (stop_) break;
    }
    if (!connected) {
      if (backoff_first) {
        backoff_first = false;
        set_state("backoff", false);
        if (!WaitUntil(Clock::now() + std::chrono::milliseconds(backoff_ms))) break;
        backoff_ms = std::min(backoff_ms * 2, config_.reconnect.max_ms);
      }
      set_state("connecting", false);
      if (modbus_connect(ctx.get()) == -1) {
        const int err = errno;
        set_error(&DeviceStatus::connection_errors,
                  std::string("connect: ") + modbus_strerror(err));
        modbus_close(ctx.get());
        set_state("backoff", false);
        if (!WaitUntil(Clock::now() + std::chrono::milliseconds(backoff_ms))) break;
        backoff_ms = std::min(backoff_ms * 2, config_.reconnect.max_ms);
        continue;
      }
      connected = true;
      fresh_connection = true;
      bad_in_a_row = 0;
      answered_since_connect = false;
      {
        std::lock_guard<std::mutex> lock(status_mu_);
        if (ever_connected) ++status_.reconnects;
        status_.state = "connected";
        status_.connected = true;
      }
      ever_connected = true;
    }

    // Next tick: wait for it, or, if a whole interval late, jump to the latest due tick.
    const auto now = Clock::now();
    const auto due = start + static_cast<std::int64_t>(k) * interval;
    std::uint64_t jumped = 0;
    if (now >= due + interval) {
      const std::uint64_t latest = static_cast<std::uint64_t>((now - start) / interval);
      jumped = latest - k;
      k = latest;
    } else if (now < due) {
      if (!WaitUntil(due)) break;
    }

    bool all_ok = true;
    for (const ReadBlock& b : blocks_) {
      const std::int64_t t0 = SystemMicros();
      const int n =
          config_.table == RegisterTable::kHolding
              ? modbus_read_registers(ctx.get(), static_cast<int>(b.start), b.count, regs.data())
              : modbus_read_input_registers(ctx.get(), static_cast<int>(b.start), b.count,
                                            regs.data());
      const int err = errno;
      const std::int64_t t1 = SystemMicros();
      if (n == b.count) {
        bad_in_a_row = 0;
        answered_since_connect = true;
        backoff_ms = config_.reconnect.initial_ms;
        const std::int64_t t_us = t0 + (t1 - t0) / 2;
        samples.clear();
        for (std::size_t m = 0; m < b.members.size(); ++m) {
          const ChannelConfig& c = config_.channels[b.members[m]];
          const std::span<const std::uint16_t> words(
              regs.data() + b.offsets[m], static_cast<std::size_t>(RegisterCount(c.type)));
          const double raw = DecodeRaw(words, c.type, c.byte_order, c.word_order);
          samples.push_back(
              StreamSample{c.channel, k, t_us, ApplyScale(raw, c.scale, c.offset), kStatusGood});
        }
        try {
          sink_.Deliver(samples);
        } catch (const std::exception& e) {
          std::lock_guard<std::mutex> lock(status_mu_);
          status_.last_error = std::string("sink: ") + e.what();
        }
        std::lock_guard<std::mutex> lock(status_mu_);
        status_.samples_delivered += samples.size();
        status_.last_sample_t_us = t_us;
        continue;
      }
      all_ok = false;
      const std::string where = "block " + std::to_string(b.start) + "+" + std::to_string(b.count);
      if (n != -1) {
        ++bad_in_a_row;
        set_error(&DeviceStatus::protocol_errors,
                  where + ": short response (" + std::to_string(n) + " registers)");
        modbus_flush(ctx.get());
        continue;
      }
      const ErrorKind kind = Classify(err);
      const std::string message = where + ": " + modbus_strerror(err);
      if (kind == ErrorKind::kException) {
        bad_in_a_row = 0;
        answered_since_connect = true;
        backoff_ms = config_.reconnect.initial_ms;
        set_error(&DeviceStatus::exceptions, message);
        continue;  // the device answered: other blocks may still be read
      }
      if (kind == ErrorKind::kConnection) {
        set_error(&DeviceStatus::connection_errors, message);
        modbus_close(ctx.get());
        connected = false;
        backoff_first = !answered_since_connect;
        set_state("connecting", false);
        break;
      }
      set_error(
          kind == ErrorKind::kTimeout ? &DeviceStatus::timeouts : &DeviceStatus::protocol_errors,
          message);
      modbus_flush(ctx.get());
      if (++bad_in_a_row >= kMaxConsecutiveBadResponses) {
        modbus_close(ctx.get());
        connected = false;
        backoff_first = !answered_since_connect;
        bad_in_a_row = 0;
        set_state("connecting", false);
      }
      break;  // a silent device would stall every remaining block of this tick
    }
    ++k;
    std::lock_guard<std::mutex> lock(status_mu_);
    status_.skipped_ticks += jumped + (all_ok ? 0 : 1);
    if (!fresh_connection) status_.late_ticks += jumped;
    fresh_connection = false;
    if (all_ok) ++status_.polls_ok;
    status_.next_counter = k;
  }
}

}  // namespace km::ingest::modbus
