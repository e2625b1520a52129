#include "ingest/modbus/modbus_device.h"

#include <modbus/modbus.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <memory>
#include <utility>

namespace km::ingest::modbus {

namespace {

// A connection to a port on this host where nothing listens can be made to itself: the kernel
// may pick that very port as the connection's own (a TCP simultaneous open). Such a "device"
// answers every request with the request itself; it is treated as a refused connection.
bool ConnectedToItself(modbus_t* ctx) {
  const int fd = modbus_get_socket(ctx);
  sockaddr_storage own{}, peer{};
  socklen_t own_len = sizeof own, peer_len = sizeof peer;
  if (fd < 0 || getsockname(fd, reinterpret_cast<sockaddr*>(&own), &own_len) != 0 ||
      getpeername(fd, reinterpret_cast<sockaddr*>(&peer), &peer_len) != 0) {
    return false;
  }
  return own_len == peer_len && std::memcmp(&own, &peer, own_len) == 0;
}

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

// What the poll loop carries from one tick to the next.
struct ModbusDevice::PollState {
  modbus_t* ctx = nullptr;
  Clock::time_point start;
  std::vector<std::uint16_t> regs = std::vector<std::uint16_t>(kMaxRegistersPerRead);
  std::vector<StreamSample> samples;
  std::uint64_t k = 0;  // next tick
  bool connected = false;
  bool ever_connected = false;
  int backoff_ms = 0;
  int bad_in_a_row = 0;
  // A connection that was lost before the device answered anything (it accepts and then
  // resets, or never answers) is re-opened only after the backoff delay, like a refused one.
  bool answered_since_connect = false;
  bool backoff_first = false;
  bool fresh_connection = false;  // connected since the previous tick
};

void ModbusDevice::SetError(std::uint64_t DeviceStatus::*counter, std::string message) {
  std::lock_guard<std::mutex> lock(status_mu_);
  ++(status_.*counter);
  status_.last_error = std::move(message);
}

void ModbusDevice::SetState(const char* state, bool connected) {
  std::lock_guard<std::mutex> lock(status_mu_);
  status_.state = state;
  status_.connected = connected;
}

void ModbusDevice::RunLoop() {
  const std::uint32_t to_s = static_cast<std::uint32_t>(config_.response_timeout_ms / 1000);
  const std::uint32_t to_us = static_cast<std::uint32_t>(config_.response_timeout_ms % 1000) * 1000;

  // One libmodbus context for this device, created and freed in this thread.
  Context ctx(modbus_new_tcp_pi(config_.host.c_str(), std::to_string(config_.port).c_str()));
  if (!ctx) {
    SetError(&DeviceStatus::connection_errors,
             std::string("cannot create a Modbus context: ") + modbus_strerror(errno));
    return;
  }
  modbus_set_slave(ctx.get(), config_.unit_id);
  modbus_set_response_timeout(ctx.get(), to_s, to_us);
  modbus_set_byte_timeout(ctx.get(), to_s, to_us);
  modbus_set_error_recovery(ctx.get(), MODBUS_ERROR_RECOVERY_NONE);

  PollState s;
  s.ctx = ctx.get();
  s.start = Clock::now();
  s.backoff_ms = config_.reconnect.initial_ms;
  while (true) {
    {
      std::lock_guard<std::mutex> lock(wait_mu_);
      if (stop_) break;
    }
    if (!s.connected) {
      const ConnectOutcome c = Connect(s);
      if (c == ConnectOutcome::kStopping) break;
      if (c == ConnectOutcome::kRetry) continue;
    }
    std::uint64_t jumped = 0;
    if (!WaitForTick(s, jumped)) break;
    const bool all_ok = PollBlocks(s);
    ++s.k;
    EndTick(s, jumped, all_ok);
  }
}

ModbusDevice::ConnectOutcome ModbusDevice::Connect(PollState& s) {
  if (s.backoff_first) {
    s.backoff_first = false;
    SetState("backoff", false);
    if (!WaitUntil(Clock::now() + std::chrono::milliseconds(s.backoff_ms))) {
      return ConnectOutcome::kStopping;
    }
    s.backoff_ms = std::min(s.backoff_ms * 2, config_.reconnect.max_ms);
  }
  SetState("connecting", false);
  const bool refused = modbus_connect(s.ctx) == -1;
  const int err = errno;
  if (refused || ConnectedToItself(s.ctx)) {
    SetError(&DeviceStatus::connection_errors,
             refused ? std::string("connect: ") + modbus_strerror(err)
                     : std::string("connect: nothing listens (the connection met itself)"));
    modbus_close(s.ctx);
    SetState("backoff", false);
    if (!WaitUntil(Clock::now() + std::chrono::milliseconds(s.backoff_ms))) {
      return ConnectOutcome::kStopping;
    }
    s.backoff_ms = std::min(s.backoff_ms * 2, config_.reconnect.max_ms);
    return ConnectOutcome::kRetry;
  }
  s.connected = true;
  s.fresh_connection = true;
  s.bad_in_a_row = 0;
  s.answered_since_connect = false;
  {
    std::lock_guard<std::mutex> lock(status_mu_);
    if (s.ever_connected) ++status_.reconnects;
    status_.state = "connected";
    status_.connected = true;
  }
  s.ever_connected = true;
  return ConnectOutcome::kConnected;
}

// Next tick: wait for it, or, if a whole interval late, jump to the latest due tick.
bool ModbusDevice::WaitForTick(PollState& s, std::uint64_t& jumped) {
  const auto interval = std::chrono::milliseconds(config_.poll_interval_ms);
  const auto now = Clock::now();
  const auto due = s.start + static_cast<std::int64_t>(s.k) * interval;
  jumped = 0;
  if (now >= due + interval) {
    const std::uint64_t latest = static_cast<std::uint64_t>((now - s.start) / interval);
    jumped = latest - s.k;
    s.k = latest;
  } else if (now < due) {
    if (!WaitUntil(due)) return false;
  }
  return true;
}

bool ModbusDevice::PollBlocks(PollState& s) {
  bool all_ok = true;
  for (const ReadBlock& b : blocks_) {
    const std::int64_t t0 = SystemMicros();
    const int n =
        config_.table == RegisterTable::kHolding
            ? modbus_read_registers(s.ctx, static_cast<int>(b.start), b.count, s.regs.data())
            : modbus_read_input_registers(s.ctx, static_cast<int>(b.start), b.count, s.regs.data());
    const int err = errno;
    const std::int64_t t1 = SystemMicros();
    if (n == b.count) {
      s.bad_in_a_row = 0;
      s.answered_since_connect = true;
      s.backoff_ms = config_.reconnect.initial_ms;
      DeliverBlock(s, b, t0 + (t1 - t0) / 2);
      continue;
    }
    all_ok = false;
    if (ReadFailed(s, b, n, err)) break;
  }
  return all_ok;
}

// The block's channels decoded and scaled, stamped with the middle of the request.
void ModbusDevice::DeliverBlock(PollState& s, const ReadBlock& b, std::int64_t t_us) {
  s.samples.clear();
  for (std::size_t m = 0; m < b.members.size(); ++m) {
    const ChannelConfig& c = config_.channels[b.members[m]];
    const std::span<const std::uint16_t> words(s.regs.data() + b.offsets[m],
                                               static_cast<std::size_t>(RegisterCount(c.type)));
    const double raw = DecodeRaw(words, c.type, c.byte_order, c.word_order);
    s.samples.push_back(
        StreamSample{c.channel, s.k, t_us, ApplyScale(raw, c.scale, c.offset), kStatusGood});
  }
  try {
    sink_.Deliver(s.samples);
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(status_mu_);
    status_.last_error = std::string("sink: ") + e.what();
  }
  std::lock_guard<std::mutex> lock(status_mu_);
  status_.samples_delivered += s.samples.size();
  status_.last_sample_t_us = t_us;
}

// A block that was not read: counted by kind. A short response or an exception lets the other
// blocks be read; a lost connection or a silent device ends the tick (true), since a silent
// device would stall every remaining block of it.
bool ModbusDevice::ReadFailed(PollState& s, const ReadBlock& b, int n, int err) {
  const std::string where = "block " + std::to_string(b.start) + "+" + std::to_string(b.count);
  if (n != -1) {
    ++s.bad_in_a_row;
    SetError(&DeviceStatus::protocol_errors,
             where + ": short response (" + std::to_string(n) + " registers)");
    modbus_flush(s.ctx);
    return false;
  }
  const ErrorKind kind = Classify(err);
  const std::string message = where + ": " + modbus_strerror(err);
  if (kind == ErrorKind::kException) {
    s.bad_in_a_row = 0;
    s.answered_since_connect = true;
    s.backoff_ms = config_.reconnect.initial_ms;
    SetError(&DeviceStatus::exceptions, message);
    return false;  // the device answered: other blocks may still be read
  }
  if (kind == ErrorKind::kConnection) {
    SetError(&DeviceStatus::connection_errors, message);
    Disconnect(s);
    return true;
  }
  SetError(kind == ErrorKind::kTimeout ? &DeviceStatus::timeouts : &DeviceStatus::protocol_errors,
           message);
  modbus_flush(s.ctx);
  if (++s.bad_in_a_row >= kMaxConsecutiveBadResponses) {
    Disconnect(s);
    s.bad_in_a_row = 0;
  }
  return true;
}

void ModbusDevice::Disconnect(PollState& s) {
  modbus_close(s.ctx);
  s.connected = false;
  s.backoff_first = !s.answered_since_connect;
  SetState("connecting", false);
}

void ModbusDevice::EndTick(PollState& s, std::uint64_t jumped, bool all_ok) {
  std::lock_guard<std::mutex> lock(status_mu_);
  status_.skipped_ticks += jumped + (all_ok ? 0 : 1);
  if (!s.fresh_connection) status_.late_ticks += jumped;
  s.fresh_connection = false;
  if (all_ok) ++status_.polls_ok;
  status_.next_counter = s.k;
}

}  // namespace km::ingest::modbus
