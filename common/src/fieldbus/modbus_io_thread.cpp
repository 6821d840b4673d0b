#include "teleop/fieldbus/modbus_io_thread.hpp"

#include <modbus.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/fieldbus/modbus_codec.hpp"
#include "teleop/runtime/background_thread.hpp"
#include "teleop/runtime/watchdog.hpp"

namespace teleop::fieldbus {

namespace {

using Counter = std::atomic<std::uint64_t>;

constexpr int kMaxReadRegisters = 125;   // Modbus application protocol v1.1b3, FC 3/4.
constexpr int kMaxReadBits = 2000;       // FC 1/2.
constexpr int kMaxWriteRegisters = 123;  // FC 16.
constexpr int kMaxWriteBits = 1968;      // FC 15.

bool IsBit(ModbusTable table) { return table == ModbusTable::kCoil || table == ModbusTable::kDiscreteInput; }

/// One request's worth of consecutive addresses in one table, and which points live in it.
struct Block {
  ModbusTable table = ModbusTable::kHoldingRegister;
  int start = 0;
  int count = 0;
  struct Member {
    int point = 0;   // index into inputs/outputs
    int offset = 0;  // first register/bit of the point inside the block
  };
  std::vector<Member> members;
};

/// Groups points into blocks of consecutive (or overlapping, for inputs) addresses per table, at most `max_*` long.
std::vector<Block> MakeBlocks(const std::vector<ModbusPoint>& points, bool allow_overlap) {
  std::vector<int> order(points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const ModbusPoint& pa = points[static_cast<std::size_t>(a)];
    const ModbusPoint& pb = points[static_cast<std::size_t>(b)];
    return pa.table != pb.table ? pa.table < pb.table : pa.address < pb.address;
  });
  std::vector<Block> blocks;
  for (int index : order) {
    const ModbusPoint& p = points[static_cast<std::size_t>(index)];
    const int width = RegisterCount(p);
    const bool bits = IsBit(p.table);
    const int limit =
        allow_overlap ? (bits ? kMaxReadBits : kMaxReadRegisters) : (bits ? kMaxWriteBits : kMaxWriteRegisters);
    if (!blocks.empty()) {
      Block& b = blocks.back();
      const int end = b.start + b.count;
      const bool joins = b.table == p.table && p.address <= end && (allow_overlap || p.address == end);
      const int new_end = std::max(end, p.address + width);
      if (joins && new_end - b.start <= limit) {
        b.count = new_end - b.start;
        b.members.push_back({index, p.address - b.start});
        continue;
      }
    }
    blocks.push_back(Block{p.table, p.address, width, {{index, 0}}});
  }
  return blocks;
}

enum class Failure : std::uint8_t { kNone, kTimeout, kException, kProtocol, kDisconnect };

Failure Classify(int err) noexcept {
  if (err == ETIMEDOUT) return Failure::kTimeout;
  if (err > MODBUS_ENOBASE && err <= MODBUS_ENOBASE + MODBUS_EXCEPTION_GATEWAY_TARGET) return Failure::kException;
  if (err == EMBBADCRC || err == EMBBADDATA || err == EMBBADEXC || err == EMBUNKEXC || err == EMBMDATA ||
      err == EMBBADSLAVE) {
    return Failure::kProtocol;
  }
  return Failure::kDisconnect;
}

void SetTimeout(modbus_t* ctx, double ms, bool byte_timeout) {
  const double us_total = std::max(0.0, ms) * 1000.0;
  const auto sec = static_cast<std::uint32_t>(us_total / 1e6);
  const auto usec = static_cast<std::uint32_t>(us_total - static_cast<double>(sec) * 1e6);
  if (byte_timeout) {
    modbus_set_byte_timeout(ctx, sec, usec);
  } else {
    modbus_set_response_timeout(ctx, sec, usec);
  }
}

}  // namespace

struct ModbusIoThread::AtomicCounters {
  Counter cycles{0};
  Counter polls_ok{0};
  Counter transactions{0};
  Counter timeouts{0};
  Counter exceptions{0};
  std::atomic<std::uint32_t> last_exception_code{0};
  Counter protocol_errors{0};
  Counter disconnects{0};
  Counter connects{0};
  Counter connect_failures{0};
  Counter fault_entries{0};
  Counter watchdog_trips{0};
  Counter command_timeouts{0};
  Counter clamped_commands{0};
  Counter non_finite_commands{0};
  Counter commands_received{0};
  Counter stale_readings{0};  // written by the loop side only
};

struct ModbusIoThread::Bus {
  modbus_t* ctx = nullptr;
  bool connected = false;
  std::vector<Block> read_blocks;
  std::vector<Block> write_blocks;
  std::vector<std::uint16_t> registers;  // scratch, sized for the largest block
  std::vector<std::uint8_t> bits;
  std::vector<std::array<std::uint16_t, 2>> output_words;  // encoded outputs, per point
  ModbusCommand command;
  bool have_command = false;
  bool outputs_safe = true;
  bool outputs_encoded = false;
  double last_command_s = 0.0;
  ModbusReading reading;  // newest good values + state, published every cycle
  bool faulted = false;
  int connect_failures_in_a_row = 0;
  double next_connect_s = 0.0;
  std::mutex wake_mutex;
  std::condition_variable wake;

  ~Bus() {
    if (ctx != nullptr) {
      if (connected) modbus_close(ctx);
      modbus_free(ctx);
    }
  }
};

ModbusIoThread::ModbusIoThread(ModbusConfig config)
    : config_(std::move(config)), bus_(std::make_unique<Bus>()), counters_(std::make_unique<AtomicCounters>()) {
  Validate(config_);
  Bus& bus = *bus_;
  bus.read_blocks = MakeBlocks(config_.inputs, true);
  bus.write_blocks = MakeBlocks(config_.outputs, false);
  int largest = 2;
  for (const Block& b : bus.read_blocks) largest = std::max(largest, b.count);
  for (const Block& b : bus.write_blocks) largest = std::max(largest, b.count);
  bus.registers.assign(static_cast<std::size_t>(largest), 0);
  bus.bits.assign(static_cast<std::size_t>(largest), 0);
  bus.output_words.assign(config_.outputs.size(), {0, 0});
  for (std::size_t i = 0; i < config_.outputs.size(); ++i) bus.command.values[i] = config_.outputs[i].safe_value;
}

ModbusIoThread::~ModbusIoThread() { Stop(); }

double ModbusIoThread::NowS() noexcept {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void ModbusIoThread::Start() {
  if (thread_.joinable() || bus_->ctx != nullptr) throw Error("modbus: Start() called twice");
  modbus_t* ctx = nullptr;
  std::string what;
  if (config_.transport == ModbusTransport::kTcp) {
    const std::string port = std::to_string(config_.tcp.port);
    ctx = modbus_new_tcp_pi(config_.tcp.host.c_str(), port.c_str());
    what = "TCP " + config_.tcp.host + ":" + port;
  } else {
    ctx = modbus_new_rtu(config_.rtu.device.c_str(), config_.rtu.baud, config_.rtu.parity, config_.rtu.data_bits,
                         config_.rtu.stop_bits);
    what = "RTU " + config_.rtu.device;
  }
  if (ctx == nullptr) {
    throw Error("modbus: cannot create the libmodbus context for " + what + ": " + modbus_strerror(errno));
  }
  bus_->ctx = ctx;
  if (modbus_set_slave(ctx, config_.unit_id) != 0) {
    throw Error("modbus: unit_id " + std::to_string(config_.unit_id) +
                " refused by libmodbus: " + modbus_strerror(errno));
  }
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);
  // 0 disables libmodbus's byte timeout (its default is 500 ms): then the whole answer must arrive within the response
  // timeout, which is what bounds a transaction.
  SetTimeout(ctx, config_.byte_timeout_ms, true);
  stop_.store(false);
  try {
    thread_ = std::thread([this] {
      runtime::BecomeBackgroundThread("teleop-modbus");
      Run();
    });
  } catch (const std::system_error& e) {
    throw Error(std::string("modbus: cannot start the I/O thread: ") + e.what());
  }
}

void ModbusIoThread::Stop() noexcept {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(bus_->wake_mutex);
    stop_.store(true);
  }
  bus_->wake.notify_all();
  thread_.join();
}

bool ModbusIoThread::WaitForFirstPoll(double timeout_s) const noexcept {
  const double deadline = NowS() + timeout_s;
  while (counters_->polls_ok.load(std::memory_order_relaxed) == 0) {
    if (!(NowS() < deadline) || !thread_.joinable()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

std::uint32_t ModbusIoThread::LatestReading(ModbusReading& out, double now_s) noexcept {
  out = readings_.Latest();
  const double age_s = now_s - out.stamp_s;
  const bool stale = out.sequence == 0 || !(age_s <= config_.stale_after_ms * 1e-3);
  if (stale) {
    out.faults |= device::kFaultCommunication;
    counters_->stale_readings.fetch_add(1, std::memory_order_relaxed);
  }
  out.stale = stale;
  loop_stale_ = stale;
  return out.faults;
}

ModbusCounters ModbusIoThread::counters() const noexcept {
  const AtomicCounters& c = *counters_;
  constexpr auto kRelaxed = std::memory_order_relaxed;
  ModbusCounters out;
  out.cycles = c.cycles.load(kRelaxed);
  out.polls_ok = c.polls_ok.load(kRelaxed);
  out.transactions = c.transactions.load(kRelaxed);
  out.timeouts = c.timeouts.load(kRelaxed);
  out.exceptions = c.exceptions.load(kRelaxed);
  out.last_exception_code = c.last_exception_code.load(kRelaxed);
  out.protocol_errors = c.protocol_errors.load(kRelaxed);
  out.disconnects = c.disconnects.load(kRelaxed);
  out.connects = c.connects.load(kRelaxed);
  out.connect_failures = c.connect_failures.load(kRelaxed);
  out.fault_entries = c.fault_entries.load(kRelaxed);
  out.watchdog_trips = c.watchdog_trips.load(kRelaxed);
  out.command_timeouts = c.command_timeouts.load(kRelaxed);
  out.clamped_commands = c.clamped_commands.load(kRelaxed);
  out.non_finite_commands = c.non_finite_commands.load(kRelaxed);
  out.commands_received = c.commands_received.load(kRelaxed);
  out.stale_readings = c.stale_readings.load(kRelaxed);
  return out;
}

namespace {

/// The I/O thread's work, apart from the class so the transaction code reads top to bottom.
class Worker {
 public:
  Worker(const ModbusConfig& config, modbus_t* ctx, std::vector<Block>& read_blocks, std::vector<Block>& write_blocks,
         std::vector<std::uint16_t>& registers, std::vector<std::uint8_t>& bits)
      : config_(config),
        ctx_(ctx),
        read_blocks_(read_blocks),
        write_blocks_(write_blocks),
        registers_(registers),
        bits_(bits) {}

  /// Writes every output block from `words`. Returns the first failure's errno (0 = all written).
  int WriteOutputs(const std::vector<std::array<std::uint16_t, 2>>& words, Counter& transactions) {
    for (const Block& b : write_blocks_) {
      for (const Block::Member& m : b.members) {
        const ModbusPoint& p = config_.outputs[static_cast<std::size_t>(m.point)];
        const auto& w = words[static_cast<std::size_t>(m.point)];
        const auto first = static_cast<std::size_t>(m.offset);
        for (std::size_t k = 0; k < static_cast<std::size_t>(RegisterCount(p)); ++k) {
          registers_[first + k] = w[k];
          bits_[first + k] = static_cast<std::uint8_t>(w[0] != 0 ? 1 : 0);
        }
      }
      transactions.fetch_add(1, std::memory_order_relaxed);
      int rc = 0;
      if (b.table == ModbusTable::kCoil) {
        rc = b.count == 1 ? modbus_write_bit(ctx_, b.start, bits_[0])
                          : modbus_write_bits(ctx_, b.start, b.count, bits_.data());
      } else {
        rc = b.count == 1 ? modbus_write_register(ctx_, b.start, registers_[0])
                          : modbus_write_registers(ctx_, b.start, b.count, registers_.data());
      }
      if (rc < 0) return errno != 0 ? errno : EIO;
    }
    return 0;
  }

  /// Reads every input block into `values`. Returns the first failure's errno (0 = all read).
  int ReadInputs(std::array<double, kMaxModbusPoints>& values, Counter& transactions) {
    for (const Block& b : read_blocks_) {
      transactions.fetch_add(1, std::memory_order_relaxed);
      int rc = 0;
      switch (b.table) {
        case ModbusTable::kCoil:
          rc = modbus_read_bits(ctx_, b.start, b.count, bits_.data());
          break;
        case ModbusTable::kDiscreteInput:
          rc = modbus_read_input_bits(ctx_, b.start, b.count, bits_.data());
          break;
        case ModbusTable::kInputRegister:
          rc = modbus_read_input_registers(ctx_, b.start, b.count, registers_.data());
          break;
        case ModbusTable::kHoldingRegister:
          rc = modbus_read_registers(ctx_, b.start, b.count, registers_.data());
          break;
      }
      if (rc < 0) return errno != 0 ? errno : EIO;
      if (rc != b.count) return EMBMDATA;
      for (const Block::Member& m : b.members) {
        const ModbusPoint& p = config_.inputs[static_cast<std::size_t>(m.point)];
        std::uint16_t words[2] = {0, 0};
        if (IsBit(b.table)) {
          words[0] = bits_[static_cast<std::size_t>(m.offset)];
        } else {
          words[0] = registers_[static_cast<std::size_t>(m.offset)];
          if (RegisterCount(p) == 2) words[1] = registers_[static_cast<std::size_t>(m.offset) + 1];
        }
        values[static_cast<std::size_t>(m.point)] = DecodePoint(p, words);
      }
    }
    return 0;
  }

 private:
  const ModbusConfig& config_;
  modbus_t* ctx_;
  std::vector<Block>& read_blocks_;
  std::vector<Block>& write_blocks_;
  std::vector<std::uint16_t>& registers_;
  std::vector<std::uint8_t>& bits_;
};

}  // namespace

/// Run()'s steps, on the I/O thread: the state it keeps across polls (the bus, the counters, the watchdog).
class ModbusIoThread::Poller {
 public:
  Poller(const ModbusConfig& config, Bus& bus, AtomicCounters& counters)
      : config_(config),
        bus_(bus),
        c_(counters),
        watchdog_(config.stale_after_ms * 1e-3),
        worker_(config, bus.ctx, bus.read_blocks, bus.write_blocks, bus.registers, bus.bits) {}

  /// The loop's newest command, or the safe values when it has none / it went stale.
  void TakeCommand(runtime::Mailbox<ModbusCommand>& commands, double now_s) noexcept {
    if (commands.Read(bus_.command)) {
      bus_.have_command = true;
      bus_.last_command_s = now_s;
      bus_.outputs_encoded = false;
      c_.commands_received.fetch_add(1, kRelaxed);
    }
    const double timeout_s = config_.command_timeout_ms * 1e-3;
    const bool safe = !bus_.have_command || (timeout_s > 0.0 && now_s - bus_.last_command_s > timeout_s);
    if (safe && !bus_.outputs_safe && bus_.have_command) c_.command_timeouts.fetch_add(1, kRelaxed);
    if (safe != bus_.outputs_safe) bus_.outputs_encoded = false;
    bus_.outputs_safe = safe;
  }

  /// The outputs' register words, when the command or its safety changed.
  void EncodeOutputs() noexcept {
    if (bus_.outputs_encoded) return;
    for (std::size_t i = 0; i < config_.outputs.size(); ++i) {
      const ModbusPoint& p = config_.outputs[i];
      const double v = bus_.outputs_safe ? p.safe_value : bus_.command.values[i];
      const ModbusEncodeStatus s = EncodePoint(p, v, bus_.output_words[i].data());
      if (s == ModbusEncodeStatus::kClamped) c_.clamped_commands.fetch_add(1, kRelaxed);
      if (s == ModbusEncodeStatus::kNonFinite) c_.non_finite_commands.fetch_add(1, kRelaxed);
    }
    bus_.outputs_encoded = true;
  }

  /// Connect (a lost connection at once, failed connects with back-off).
  void Connect(double now_s) noexcept {
    if (bus_.connected || now_s < bus_.next_connect_s) return;
    SetTimeout(bus_.ctx, config_.connect_timeout_ms, false);
    if (modbus_connect(bus_.ctx) == 0) {
      bus_.connected = true;
      bus_.connect_failures_in_a_row = 0;
      c_.connects.fetch_add(1, kRelaxed);
    } else {
      c_.connect_failures.fetch_add(1, kRelaxed);
      modbus_close(bus_.ctx);  // releases a half-opened socket/descriptor
      const double backoff_ms =
          std::min(config_.reconnect_max_ms,
                   config_.reconnect_initial_ms * std::pow(2.0, std::min(bus_.connect_failures_in_a_row, 30)));
      ++bus_.connect_failures_in_a_row;
      bus_.next_connect_s = NowS() + backoff_ms * 1e-3;
      EnterFault();
    }
    SetTimeout(bus_.ctx, config_.response_timeout_ms, false);
  }

  /// One poll: all outputs, then all inputs.
  void Poll() noexcept {
    if (!bus_.connected) return;
    int err = worker_.WriteOutputs(bus_.output_words, c_.transactions);
    if (err == 0) err = worker_.ReadInputs(values_, c_.transactions);
    if (err != 0) {
      CountFailure(err);
      return;
    }
    const double done_s = NowS();
    bus_.reading.values = values_;
    bus_.reading.sequence += 1;
    bus_.reading.stamp_s = done_s;
    bus_.faulted = false;
    watchdog_.Feed(done_s);
    c_.polls_ok.fetch_add(1, kRelaxed);
  }

  /// The thread's own watchdog (no good poll for stale_after_ms is a fault even if no transaction said so), then
  /// the reading the loop gets this cycle.
  const ModbusReading& Reading() noexcept {
    const std::uint64_t trips_before = watchdog_.trips();
    if (!watchdog_.Fresh(NowS())) {
      if (watchdog_.trips() != trips_before) c_.watchdog_trips.fetch_add(1, kRelaxed);
      if (watchdog_.expired()) EnterFault();
    }
    bus_.reading.faults = bus_.faulted ? device::kFaultCommunication : device::kFaultNone;
    bus_.reading.failed_cycles = bus_.faulted ? bus_.reading.failed_cycles + 1 : 0;
    bus_.reading.outputs_safe = bus_.outputs_safe;
    return bus_.reading;
  }

  /// At stop: safe outputs, best effort, once; then the reading that says nothing polls any more.
  const ModbusReading& Stop() noexcept {
    if (bus_.connected && !config_.outputs.empty()) {
      for (std::size_t i = 0; i < config_.outputs.size(); ++i) {
        const ModbusPoint& p = config_.outputs[i];
        (void)EncodePoint(p, p.safe_value, bus_.output_words[i].data());
      }
      bus_.outputs_safe = true;
      (void)worker_.WriteOutputs(bus_.output_words, c_.transactions);
    }
    Disconnect();
    bus_.reading.faults = device::kFaultCommunication;
    bus_.reading.outputs_safe = true;
    return bus_.reading;
  }

 private:
  static constexpr auto kRelaxed = std::memory_order_relaxed;

  void EnterFault() noexcept {
    if (!bus_.faulted) c_.fault_entries.fetch_add(1, kRelaxed);
    bus_.faulted = true;
  }
  void Disconnect() noexcept {
    if (bus_.connected) modbus_close(bus_.ctx);
    bus_.connected = false;
  }
  /// TCP: a late answer would arrive in the next transaction's place; a new connection drops it. RTU: flush.
  void Resynchronize() noexcept {
    if (config_.transport == ModbusTransport::kTcp) {
      Disconnect();
    } else {
      modbus_flush(bus_.ctx);
    }
  }
  void CountFailure(int err) noexcept {
    switch (Classify(err)) {
      case Failure::kTimeout:
        c_.timeouts.fetch_add(1, kRelaxed);
        Resynchronize();
        break;
      case Failure::kException:
        c_.exceptions.fetch_add(1, kRelaxed);
        c_.last_exception_code.store(static_cast<std::uint32_t>(err - MODBUS_ENOBASE), kRelaxed);
        break;  // a complete, well-formed answer: the link is in step
      case Failure::kProtocol:
        c_.protocol_errors.fetch_add(1, kRelaxed);
        Resynchronize();
        break;
      case Failure::kDisconnect:
      case Failure::kNone:
        c_.disconnects.fetch_add(1, kRelaxed);
        Disconnect();
        break;
    }
    EnterFault();
  }

  const ModbusConfig& config_;
  Bus& bus_;
  AtomicCounters& c_;
  runtime::LinkWatchdog watchdog_;
  Worker worker_;
  std::array<double, kMaxModbusPoints> values_{};
};

void ModbusIoThread::Run() noexcept {
  Poller poller(config_, *bus_, *counters_);
  const double period_s = config_.poll_period_ms * 1e-3;
  double cycle_start_s = NowS();
  while (!stop_.load(std::memory_order_relaxed)) {
    counters_->cycles.fetch_add(1, std::memory_order_relaxed);
    const double now_s = NowS();
    poller.TakeCommand(commands_, now_s);
    poller.EncodeOutputs();
    poller.Connect(now_s);
    poller.Poll();
    readings_.Write(poller.Reading());
    // Sleep to the next cycle; a late cycle starts the next one at once, without trying to catch up.
    cycle_start_s = std::max(cycle_start_s + period_s, NowS() - period_s);
    const double wait_s = cycle_start_s - NowS();
    if (wait_s > 0.0) {
      std::unique_lock<std::mutex> lock(bus_->wake_mutex);
      bus_->wake.wait_for(lock, std::chrono::duration<double>(wait_s), [this] { return stop_.load(); });
    }
  }
  readings_.Write(poller.Stop());
}

}  // namespace teleop::fieldbus
