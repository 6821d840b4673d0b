// The `telemetry:` section.

#include "sections.hpp"

namespace teleop::config::sections {

void ParseTelemetry(const Field& f, TelemetryConfig& telemetry) {
  const Map map(f, {"csv", "decimation", "ring_capacity"});
  if (auto v = map.Optional("csv")) telemetry.csv_path = v->AsString();
  if (auto v = map.Optional("decimation")) telemetry.decimation = IntInRange(*v, 1, 1'000'000);
  if (auto v = map.Optional("ring_capacity")) telemetry.ring_capacity = IntInRange(*v, 16, 1 << 24);
}

/// The start-up stability check (docs/stability.md, "In the processes"). Absent keys keep StabilityConfig's defaults.

}  // namespace teleop::config::sections
