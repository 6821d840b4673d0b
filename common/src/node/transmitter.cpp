#include "transmitter.hpp"

#include <algorithm>

namespace teleop::node {

namespace {

void CopyToWire(const DofVector& v, std::array<double, proto::kMaxWireDof>& out) noexcept {
  for (int i = 0; i < v.size(); ++i) out[static_cast<std::size_t>(i)] = v[i];
}

}  // namespace

Transmitter::Transmitter(Role role, int dof, transport::Link& link, const NodeClock& clock)
    : link_(link), clock_(clock) {
  state_.outgoing.sender = link::ToSender(role);
  state_.outgoing.dof = static_cast<std::uint8_t>(dof);
}

std::uint8_t Transmitter::Send(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                               bool stopping) noexcept {
  proto::SampleMessage& out = state_.outgoing;
  const control::ThreeChannelLaw::Output& law = applied.law;
  out.sequence = state_.sequence++;
  out.echo_time_ns = peer.have_peer ? peer.sample->sender_time_ns : 0;
  std::uint8_t flags = proto::kFlagEnabled;
  if (sensed.local_faults != device::kFaultNone || applied.nonfinite) flags |= proto::kFlagFault;
  if ((peer.have_peer && !peer.fresh) || peer.link_faulted) flags |= proto::kFlagPeerLost;
  if (law.status == control::ThreeChannelLaw::StepStatus::kSaturated) flags |= proto::kFlagSaturated;
  if (law.fixture_penetration_m > 0.0) flags |= proto::kFlagInFixture;
  if (stopping) flags |= proto::kFlagShutdown;
  if (applied.clutch_flag) flags |= proto::kFlagClutched;
  out.flags = flags;
  if ((flags & proto::kFlagFault) != 0) {
    // The values are not to be used (the peer decouples on the flag), and a NaN or absurd reading would make the
    // sample unencodable or implausible and the flag would never arrive: send zeros with it.
    out.position_m.fill(0.0);
    out.velocity_m_per_s.fill(0.0);
    out.force_N.fill(0.0);
  } else {
    CopyToWire(applied.law_input.position_m, out.position_m);  // the reading + a re-indexed master's offset
    CopyToWire(law.velocity_m_per_s, out.velocity_m_per_s);
    CopyToWire(sensed.reading->force_N, out.force_N);
  }
  // Time-domain passivity, energy_exchange: this port's energies travel with the sample (the energy block).
  out.has_energy = applied.passivity_mode == control::PassivityMode::kEnergyExchange;
  if (out.has_energy) {
    out.input_energy_J = applied.passivity.input_energy_J;
    out.output_energy_J = applied.passivity.output_energy_J;
  }
  // Send time and echo age taken right before the send call (docs/protocol.md, "Round-trip time").
  const std::int64_t send_ns = clock_.Now();
  out.sender_time_ns = static_cast<std::uint64_t>(send_ns);
  out.echo_age_ns =
      peer.have_peer ? static_cast<std::uint32_t>(std::clamp<std::int64_t>(send_ns - peer.rx_ns, 0, 0xFFFFFFFF)) : 0;
  (void)link_.Send(out);  // a refused send is counted by the link
  return flags;
}

void Transmitter::SendShutdown() noexcept {
  state_.outgoing.flags = proto::kFlagShutdown;
  state_.outgoing.sequence = state_.sequence++;
  (void)link_.Send(state_.outgoing);
}

}  // namespace teleop::node
