#include "teleop/transport/impaired_link.hpp"

#include <time.h>

#include <array>
#include <span>
#include <string>

#include "sample_intake.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

std::int64_t MonotonicNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

// The emulated stage: the model's delay line and the receive path behind it, with its own counters.
struct ImpairedLink::Stage {
  Stage(const ImpairmentConfig& impairments, std::uint64_t seed, proto::SenderRole expected_peer)
      : model(impairments, seed, "link.emulate"), intake(expected_peer) {}
  ImpairmentModel model;
  detail::SampleIntake intake;
  LinkCounters counters{};
  proto::SampleMessage sample{};
  std::array<std::uint8_t, ImpairmentModel::kMaxDatagramBytes> bytes{};
};

ImpairedLink::ImpairedLink(std::unique_ptr<Link> inner, const ImpairmentConfig& impairments, std::uint64_t seed,
                           proto::SenderRole expected_peer, Clock clock)
    : inner_(std::move(inner)), clock_(clock != nullptr ? clock : &MonotonicNs) {
  if (inner_ == nullptr) throw Error("link.emulate: no link to wrap");
  stage_ = std::make_unique<Stage>(impairments, seed, expected_peer);
  stage_->model.Start(clock_());
  epoch_ = inner_->session_epoch();
  Merge();
}

ImpairedLink::~ImpairedLink() = default;

bool ImpairedLink::Send(const proto::SampleMessage& message) noexcept {
  const bool ok = inner_->Send(message);
  counters_.sent = inner_->counters().sent;
  counters_.send_errors = inner_->counters().send_errors;
  return ok;
}

bool ImpairedLink::Poll(proto::SampleMessage& newest) noexcept {
  Stage& s = *stage_;
  const std::int64_t now_ns = clock_();
  const bool fresh = inner_->Poll(s.sample);
  if (inner_->session_epoch() != epoch_) {
    // A new session (peer restart): its sequence numbers start again, so what is in flight from the old one and
    // the tracker's memory of it are dropped.
    epoch_ = inner_->session_epoch();
    s.model.Clear();
    s.intake.ResetTracker();
  }
  if (fresh) {
    // A sample the encoder refuses (none that the wrapped link accepts) is offered empty: counted dropped_overflow.
    const std::size_t size = proto::EncodeSample(s.sample, s.bytes);
    (void)s.model.Offer(std::span<const std::uint8_t>(s.bytes.data(), size), now_ns);
  }
  s.intake.Begin();
  s.model.BeginDelivery(now_ns);
  ImpairmentModel::Delivery d;
  std::int64_t newest_due_ns = 0;
  while (s.model.NextDelivery(d)) {
    if (s.intake.Offer(d.bytes, s.counters)) newest_due_ns = d.due_ns;
  }
  const bool got = s.intake.Finish(newest, s.counters);
  if (got) newest_receive_time_ns_ = newest_due_ns;
  Merge();
  return got;
}

void ImpairedLink::Merge() noexcept {
  const LinkCounters& in = inner_->counters();
  const LinkCounters& em = stage_->counters;
  LinkCounters& c = counters_;
  c.sent = in.sent;
  c.send_errors = in.send_errors;
  c.bus_errors = in.bus_errors + em.bus_errors;
  // Every datagram the wrapped link read but did not hand on, plus every one the emulated stage read.
  c.received = (in.received - in.accepted) + em.received;
  c.accepted = em.accepted;
  c.lost = em.lost;
  c.superseded = in.superseded + em.superseded;
  c.reordered = in.reordered + em.reordered;
  c.duplicates = in.duplicates + em.duplicates;
  c.rejected = in.rejected + em.rejected;
  c.wrong_sender = in.wrong_sender + em.wrong_sender;
  for (std::size_t i = 0; i < c.rejected_by_reason.size(); ++i) {
    c.rejected_by_reason[i] = in.rejected_by_reason[i] + em.rejected_by_reason[i];
  }
  // The authenticated session is the wrapped link's (the emulated stage sees only its accepted samples).
  c.secure_rejected_by_reason = in.secure_rejected_by_reason;
  c.handshake_messages = in.handshake_messages;
  c.sessions = in.sessions;
  c.handshakes_started = in.handshakes_started;
  c.send_no_session = in.send_no_session;
  c.peer_protocol_version = in.peer_protocol_version;
}

std::string ImpairedLink::Describe() const {
  return inner_->Describe() + " + emulate (receive side: " + stage_->model.Describe() + ")";
}

std::string ImpairedLink::Summary() const {
  const LinkCounters& in = inner_->counters();
  std::string out = "wrapped link: received " + std::to_string(in.received) + ", accepted " +
                    std::to_string(in.accepted) + ", lost " + std::to_string(in.lost) + ", superseded " +
                    std::to_string(in.superseded) + ", rejected " + std::to_string(in.rejected);
  const std::string inner_summary = inner_->Summary();
  if (!inner_summary.empty()) out += "; " + inner_summary;
  return out;
}

const ImpairmentCounters& ImpairedLink::impairments() const noexcept { return stage_->model.counters(); }

const ImpairmentCounters* EmulationCountersOf(const Link& link) noexcept {
  const auto* impaired = dynamic_cast<const ImpairedLink*>(&link);
  return impaired != nullptr ? &impaired->impairments() : nullptr;
}

}  // namespace teleop::transport
