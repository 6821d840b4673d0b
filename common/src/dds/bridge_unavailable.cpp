// The bridge of a build without Cyclone DDS (TELEOP_DDS=OFF): a config with dds.enabled is refused at start-up.
#include "teleop/dds/bridge.hpp"
#include "teleop/error.hpp"

namespace teleop::dds {

struct Bridge::Impl {};

const char* EventKindName(node::Event::Kind /*kind*/) noexcept { return "unknown"; }

bool Bridge::Available() noexcept { return false; }

Bridge::Bridge(const BridgeConfig& /*config*/, Role /*role*/, double /*loop_rate_hz*/) {
  throw Error(
      "dds.enabled is true but this build has no DDS bridge (configured with TELEOP_DDS=OFF or without Cyclone DDS); "
      "install cyclonedds-dev and cyclonedds-tools and rebuild, or set dds.enabled: false");
}

Bridge::~Bridge() = default;
bool Bridge::PushState(const BridgeSample& /*sample*/) noexcept { return false; }
void Bridge::OnEvent(const node::Event& /*event*/) noexcept {}
void Bridge::PublishSummary(const node::RunSummary& /*summary*/, const std::string& /*summary_json*/) {}
void Bridge::Stop() {}
std::uint64_t Bridge::states_published() const noexcept { return 0; }
std::uint64_t Bridge::states_dropped() const noexcept { return 0; }
std::uint64_t Bridge::events_published() const noexcept { return 0; }
std::uint64_t Bridge::events_dropped() const noexcept { return 0; }

}  // namespace teleop::dds
