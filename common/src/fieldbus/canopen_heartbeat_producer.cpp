#include "teleop/fieldbus/canopen_heartbeat_producer.hpp"

#include <fmt/format.h>

#include <cmath>

#include "teleop/error.hpp"

namespace teleop::fieldbus::canopen {

HeartbeatProducer::HeartbeatProducer(transport::CanPort& port, std::uint8_t node_id, double period_ms)
    : port_(port), node_id_(node_id), period_ns_(0) {
  if (!IsValidNodeId(node_id)) throw Error(fmt::format("heartbeat producer: node-ID {} is not 1..127", node_id));
  if (!(period_ms > 0.0) || period_ms > 65535.0) {
    throw Error(fmt::format("heartbeat producer: period {} ms is not in (0, 65535]", period_ms));
  }
  period_ns_ = static_cast<std::uint64_t>(std::llround(period_ms * 1e6));
}

transport::CanWriteStatus HeartbeatProducer::Service(std::uint64_t now_ns) noexcept {
  if (started_ && now_ns < next_ns_) return transport::CanWriteStatus::kOk;
  return SendNow(now_ns);
}

transport::CanWriteStatus HeartbeatProducer::SendNow(std::uint64_t now_ns) noexcept {
  const transport::CanWriteStatus status = port_.Write(EncodeHeartbeat(node_id_, NmtState::kOperational));
  if (status == transport::CanWriteStatus::kOk) {
    ++counters_.sent;
    started_ = true;
    next_ns_ = now_ns + period_ns_;
  } else {
    ++counters_.write_failures;
  }
  return status;
}

}  // namespace teleop::fieldbus::canopen
