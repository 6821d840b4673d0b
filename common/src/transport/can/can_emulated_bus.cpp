#include "teleop/transport/can_emulated_bus.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <string>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::transport {

using proto::can::CanFrame;

namespace {

// Error flag (6) + echoed flags (≤ 6) + error delimiter (8) + intermission (3), in nominal bits.
constexpr double kErrorFrameBits = 23.0;
constexpr int kWarningLevel = 96;
constexpr int kPassiveLevel = 128;
constexpr int kBusOffLevel = 256;

// Arbitration order: base identifier first; a standard data frame beats an extended one with the same base
// identifier (its IDE bit is dominant where the extended frame's SRR/IDE are recessive).
std::uint64_t ArbitrationKey(const CanFrame& f) noexcept {
  if (!f.extended) return std::uint64_t{f.id & proto::can::kMaxStandardId} << 20;
  const std::uint64_t base = (f.id >> 18) & proto::can::kMaxStandardId;
  return (base << 20) | (std::uint64_t{3} << 18) | (f.id & 0x3FFFFu);
}

std::uint64_t ToNs(double seconds) noexcept { return static_cast<std::uint64_t>(std::llround(seconds * 1e9)); }

class EmulatedCanPort final : public CanPort {
 public:
  EmulatedCanPort(EmulatedCanBus& bus, int node) : bus_(bus), node_(node) {}
  EmulatedCanPort(EmulatedCanBus& bus, int node, CanReceiveOptions options)
      : bus_(bus), node_(node), filtered_(true), options_(std::move(options)) {}
  CanWriteStatus Write(const CanFrame& frame) noexcept override {
    if (filtered_ && frame.fd && !options_.fd) return CanWriteStatus::kError;  // as SocketCAN without FD frames
    return bus_.Submit(node_, frame);
  }
  bool Read(CanFrame& frame) noexcept override {
    std::uint64_t receive_ns = 0;
    while (bus_.Receive(node_, frame, receive_ns)) {
      if (!filtered_ || Accepts(options_, frame)) {
        receive_ns_ = static_cast<std::int64_t>(receive_ns);
        return true;
      }
    }
    return false;
  }
  // On the bus clock: the bus advances to each transmission's end (or the deadline) and sleeps in between.
  bool WaitReadable(std::int64_t deadline_ns) noexcept override {
    const auto deadline = static_cast<std::uint64_t>(std::max<std::int64_t>(deadline_ns, 0));
    for (;;) {
      if (bus_.Pending(node_)) return true;
      if (bus_.now_ns() >= deadline) return false;
      bus_.SleepUntil(std::min(bus_.NextEvent_ns(), deadline));
    }
  }
  std::int64_t now_ns() const noexcept override { return static_cast<std::int64_t>(bus_.now_ns()); }
  std::int64_t receive_time_ns() const noexcept override { return receive_ns_; }
  std::string Describe() const override {
    std::string text = "emulated-can in-process node " + std::to_string(node_);
    if (filtered_) text += ", " + std::to_string(options_.filters.size()) + " filters";
    return text;
  }

 private:
  EmulatedCanBus& bus_;
  int node_;
  bool filtered_ = false;
  CanReceiveOptions options_{};
  std::int64_t receive_ns_ = 0;
};

void SleepOnMonotonic(std::uint64_t until_ns) {
  timespec until{};
  until.tv_sec = static_cast<time_t>(until_ns / 1'000'000'000);
  until.tv_nsec = static_cast<long>(until_ns % 1'000'000'000);
  (void)clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr);
}

}  // namespace

struct EmulatedCanBus::Node {
  struct TxEntry {
    CanFrame frame{};
    std::uint64_t submit_ns = 0;
    std::uint64_t entry = 0;
  };
  std::vector<TxEntry> tx;             // capacity reserved at AddNode
  std::vector<CanFrame> rx;            // ring
  std::vector<std::uint64_t> rx_time;  // bus time each rx entry arrived, same ring
  std::size_t rx_head = 0;
  std::size_t rx_count = 0;
  int tec = 0;
  int rec = 0;
  bool bus_off = false;
};

std::uint64_t EmulatedCanBus::SteadyNow_ns() noexcept {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
          .count());
}

EmulatedCanBus::EmulatedCanBus(const EmulatedCanBusConfig& config, Clock clock)
    : config_(config),
      rates_{config.nominal_bitrate_bit_per_s, config.data_bitrate_bit_per_s},
      clock_(std::move(clock)),
      sleeper_(&SleepOnMonotonic) {
  if (!(config.nominal_bitrate_bit_per_s > 0) || !(config.data_bitrate_bit_per_s > 0)) {
    throw Error("emulated CAN bus: bit rates must be > 0 bit/s");
  }
  if (!(config.load_ceiling > 0.0 && config.load_ceiling <= 1.0)) {
    throw Error("emulated CAN bus: load_ceiling must be in (0, 1], got " + std::to_string(config.load_ceiling));
  }
  if (config.tx_queue_frames < 1 || config.rx_queue_frames < 1) {
    throw Error("emulated CAN bus: tx_queue_frames and rx_queue_frames must be ≥ 1");
  }
  if (!clock_) throw Error("emulated CAN bus: no clock");
  nodes_.reserve(64);
}

EmulatedCanBus::~EmulatedCanBus() = default;

int EmulatedCanBus::AddNode() {
  if (nodes_.size() == nodes_.capacity()) throw Error("emulated CAN bus: at most 64 nodes");
  Node& n = nodes_.emplace_back();
  n.tx.reserve(static_cast<std::size_t>(config_.tx_queue_frames));
  n.rx.resize(static_cast<std::size_t>(config_.rx_queue_frames));
  n.rx_time.resize(static_cast<std::size_t>(config_.rx_queue_frames));
  return static_cast<int>(nodes_.size()) - 1;
}

std::unique_ptr<CanPort> EmulatedCanBus::MakePort(int node) {
  if (node < 0 || node >= node_count()) throw Error("emulated CAN bus: no node " + std::to_string(node));
  return std::make_unique<EmulatedCanPort>(*this, node);
}

std::unique_ptr<CanPort> EmulatedCanBus::MakePort(int node, CanReceiveOptions options) {
  if (node < 0 || node >= node_count()) throw Error("emulated CAN bus: no node " + std::to_string(node));
  if (options.filters.size() > kMaxCanFilters) {
    throw Error("emulated CAN bus: " + std::to_string(options.filters.size()) + " receive filters, at most " +
                std::to_string(kMaxCanFilters));
  }
  return std::make_unique<EmulatedCanPort>(*this, node, std::move(options));
}

int EmulatedCanBus::node_count() const noexcept { return static_cast<int>(nodes_.size()); }

int EmulatedCanBus::transmit_error_counter(int node) const noexcept {
  return node >= 0 && node < node_count() ? nodes_[static_cast<std::size_t>(node)].tec : 0;
}

bool EmulatedCanBus::is_bus_off(int node) const noexcept {
  return node >= 0 && node < node_count() && nodes_[static_cast<std::size_t>(node)].bus_off;
}

double EmulatedCanBus::FrameTime_s(const CanFrame& frame) const noexcept {
  return proto::can::FrameTime_s(frame.fd, frame.brs, frame.extended, frame.len, rates_);
}

CanWriteStatus EmulatedCanBus::Submit(int node, const CanFrame& frame) noexcept {
  if (node < 0 || node >= node_count()) return CanWriteStatus::kError;
  const bool length_ok = frame.fd ? proto::can::IsValidFdLength(frame.len) : frame.len <= 8;
  if (frame.error || !length_ok) return CanWriteStatus::kError;
  Run();
  Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.bus_off) {
    ++stats_.tx_refused;
    return CanWriteStatus::kBusOff;
  }
  if (n.tx.size() >= n.tx.capacity()) {
    ++stats_.tx_refused;
    return CanWriteStatus::kBufferFull;
  }
  n.tx.push_back(Node::TxEntry{frame, clock_(), next_entry_++});
  Run();
  return CanWriteStatus::kOk;
}

bool EmulatedCanBus::Receive(int node, CanFrame& frame) noexcept {
  std::uint64_t receive_ns = 0;
  return Receive(node, frame, receive_ns);
}

bool EmulatedCanBus::Pending(int node) noexcept {
  if (node < 0 || node >= node_count()) return false;
  Run();
  return nodes_[static_cast<std::size_t>(node)].rx_count > 0;
}

void EmulatedCanBus::SetSleeper(Sleeper sleeper) {
  if (!sleeper) throw Error("emulated CAN bus: no sleeper");
  sleeper_ = std::move(sleeper);
}

void EmulatedCanBus::SleepUntil(std::uint64_t until_ns) noexcept {
  if (clock_() < until_ns) sleeper_(until_ns);
}

bool EmulatedCanBus::Receive(int node, CanFrame& frame, std::uint64_t& receive_ns) noexcept {
  if (node < 0 || node >= node_count()) return false;
  Run();
  Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.rx_count == 0) return false;
  frame = n.rx[n.rx_head];
  receive_ns = n.rx_time[n.rx_head];
  n.rx_head = (n.rx_head + 1) % n.rx.size();
  --n.rx_count;
  return true;
}

void EmulatedCanBus::Run() noexcept {
  const std::uint64_t now = clock_();
  for (;;) {
    if (in_flight_.active) {
      if (in_flight_.end_ns > now) return;
      Finish();
      continue;
    }
    if (!StartNext(now)) return;
  }
}

bool EmulatedCanBus::StartNext(std::uint64_t now) noexcept {
  std::uint64_t earliest = std::numeric_limits<std::uint64_t>::max();
  for (const Node& n : nodes_) {
    for (const Node::TxEntry& e : n.tx) earliest = std::min(earliest, e.submit_ns);
  }
  if (earliest == std::numeric_limits<std::uint64_t>::max()) return false;
  const std::uint64_t start = std::max(bus_free_ns_, earliest);
  if (start > now) return false;
  // Arbitration among every frame pending at `start`.
  const Node::TxEntry* winner = nullptr;
  int winner_node = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    for (const Node::TxEntry& e : nodes_[i].tx) {
      if (e.submit_ns > start) continue;
      if (winner == nullptr || ArbitrationKey(e.frame) < ArbitrationKey(winner->frame) ||
          (ArbitrationKey(e.frame) == ArbitrationKey(winner->frame) && e.entry < winner->entry)) {
        winner = &e;
        winner_node = static_cast<int>(i);
      }
    }
  }
  if (winner == nullptr) return false;
  const bool destroyed = errors_to_inject_ > 0;
  if (destroyed) --errors_to_inject_;
  double duration_s = FrameTime_s(winner->frame) / config_.load_ceiling;
  if (destroyed) duration_s += kErrorFrameBits / config_.nominal_bitrate_bit_per_s;
  in_flight_.active = true;
  in_flight_.destroyed = destroyed;
  in_flight_.node = winner_node;
  in_flight_.entry = winner->entry;
  in_flight_.frame = winner->frame;
  in_flight_.end_ns = start + ToNs(duration_s);
  stats_.busy_ns += in_flight_.end_ns - start;
  return true;
}

void EmulatedCanBus::Finish() noexcept {
  in_flight_.active = false;
  bus_free_ns_ = in_flight_.end_ns;
  const auto sender = static_cast<std::size_t>(in_flight_.node);
  Node& tx = nodes_[sender];
  if (in_flight_.destroyed) {
    ++stats_.error_frames;
    for (std::size_t i = 0; i < nodes_.size(); ++i) {
      Node& n = nodes_[i];
      if (n.bus_off) continue;
      DeliverError(static_cast<int>(i), proto::can::kErrProtocol | proto::can::kErrBusError, 0, in_flight_.end_ns);
      if (i == sender) continue;
      const int before = n.rec;
      n.rec = std::min(n.rec + 1, kPassiveLevel);
      if (before < kWarningLevel && n.rec >= kWarningLevel) {
        DeliverError(static_cast<int>(i), proto::can::kErrController, proto::can::kCtrlRxWarning, in_flight_.end_ns);
      }
      if (before < kPassiveLevel && n.rec >= kPassiveLevel) {
        DeliverError(static_cast<int>(i), proto::can::kErrController, proto::can::kCtrlRxPassive, in_flight_.end_ns);
      }
    }
    if (tx.bus_off) return;  // forced bus-off while the frame was on the wire
    const int before = tx.tec;
    tx.tec += 8;
    if (before < kWarningLevel && tx.tec >= kWarningLevel) {
      DeliverError(in_flight_.node, proto::can::kErrController, proto::can::kCtrlTxWarning, in_flight_.end_ns);
    }
    if (before < kPassiveLevel && tx.tec >= kPassiveLevel) {
      DeliverError(in_flight_.node, proto::can::kErrController, proto::can::kCtrlTxPassive, in_flight_.end_ns);
    }
    if (tx.tec >= kBusOffLevel) {
      tx.bus_off = true;
      tx.tx.clear();
      DeliverError(in_flight_.node, proto::can::kErrBusOff, 0, in_flight_.end_ns);
    }
    return;  // the frame stays queued: retransmitted at the next arbitration
  }
  for (auto it = tx.tx.begin(); it != tx.tx.end(); ++it) {
    if (it->entry == in_flight_.entry) {
      tx.tx.erase(it);
      break;
    }
  }
  ++stats_.frames_delivered;
  tx.tec = std::max(0, tx.tec - 1);
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (i == sender || nodes_[i].bus_off) continue;
    nodes_[i].rec = std::max(0, nodes_[i].rec - 1);
    Deliver(static_cast<int>(i), in_flight_.frame, in_flight_.end_ns);
  }
}

void EmulatedCanBus::Deliver(int node, const CanFrame& frame, std::uint64_t time_ns) noexcept {
  Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.rx_count == n.rx.size()) {
    ++stats_.rx_overflows;
    return;
  }
  n.rx[(n.rx_head + n.rx_count) % n.rx.size()] = frame;
  n.rx_time[(n.rx_head + n.rx_count) % n.rx.size()] = time_ns;
  ++n.rx_count;
}

void EmulatedCanBus::DeliverError(int node, std::uint32_t error_class, std::uint8_t controller,
                                  std::uint64_t time_ns) noexcept {
  CanFrame f{};
  f.error = true;
  f.error_class = error_class;
  f.len = 8;
  f.data[1] = controller;
  Deliver(node, f, time_ns);
}

std::uint64_t EmulatedCanBus::NextEvent_ns() const noexcept {
  if (in_flight_.active) return in_flight_.end_ns;
  std::uint64_t earliest = std::numeric_limits<std::uint64_t>::max();
  for (const Node& n : nodes_) {
    for (const Node::TxEntry& e : n.tx) earliest = std::min(earliest, e.submit_ns);
  }
  if (earliest == std::numeric_limits<std::uint64_t>::max()) return earliest;
  return std::max(bus_free_ns_, earliest);
}

void EmulatedCanBus::InjectErrors(int count) noexcept { errors_to_inject_ += std::max(0, count); }

void EmulatedCanBus::ForceBusOff(int node) noexcept {
  if (node < 0 || node >= node_count()) return;
  Run();
  Node& n = nodes_[static_cast<std::size_t>(node)];
  if (n.bus_off) return;
  n.bus_off = true;
  n.tx.clear();
  DeliverError(node, proto::can::kErrBusOff, 0, clock_());
}

void EmulatedCanBus::Restart(int node) noexcept {
  if (node < 0 || node >= node_count()) return;
  Run();
  Node& n = nodes_[static_cast<std::size_t>(node)];
  n.bus_off = false;
  n.tec = 0;
  n.rec = 0;
  DeliverError(node, proto::can::kErrRestarted, 0, clock_());
}

}  // namespace teleop::transport
