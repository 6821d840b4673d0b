#pragma once

// The `link.delay_recheck` keys, each written once (teleop/config/key_table.hpp): the reader (link_section.cpp) and
// the rows of docs/configuration.md come from this table; the defaults are link::LinkConfig::DelayRecheck's member
// initialisers (teleop/link/link_config.hpp), the one place they are written.

#include <array>

#include "teleop/config/key_table.hpp"
#include "teleop/link/link_config.hpp"

namespace teleop::config::delay_recheck_keys {

inline constexpr link::LinkConfig::DelayRecheck kDefaults{};

inline const KeySpec kEnabled{.key = "enabled",
                              .type = KeyType::kBool,
                              .meaning =
                                  "Re-check the stability at the measured data age and ramp the fixture to the "
                                  "new limit (docs/stability.md, \"Run-time re-check\").",
                              .default_bool = kDefaults.enabled};
inline const KeySpec kWindow{
    .key = "window_s",
    .unit = "s",
    .range = KeyRange::kInRange,
    .default_value = kDefaults.window_s,
    .meaning = "The percentile is over this much of the newest data ages (sampled every 10 ms).",
    .low = 0.05,
    .high = 30.0};
inline const KeySpec kPercentile{.key = "percentile",
                                 .range = KeyRange::kInRange,
                                 .default_value = kDefaults.percentile,
                                 .meaning = "Which percentile of the window is compared (0.99: the 99th).",
                                 .low = 0.5,
                                 .high = 1.0};
inline const KeySpec kTriggerRatio{.key = "trigger_ratio",
                                   .range = KeyRange::kInRange,
                                   .default_value = kDefaults.trigger_ratio,
                                   .meaning =
                                       "Slower: the percentile exceeds the age the start-up check assumed (one "
                                       "period + its link delay) × this; again at each further × this.",
                                   .low = 1.01,
                                   .high = 100.0};
inline const KeySpec kRecoverRatio{.key = "recover_ratio",
                                   .range = KeyRange::kInRange,
                                   .default_value = kDefaults.recover_ratio,
                                   .meaning =
                                       "Recovered: the percentile at or below the assumed age × this (at most "
                                       "trigger_ratio) ..",
                                   .low = 1.0,
                                   .high = 100.0};
inline const KeySpec kRecoverHold{.key = "recover_hold_s",
                                  .unit = "s",
                                  .range = KeyRange::kInRange,
                                  .default_value = kDefaults.recover_hold_s,
                                  .meaning = ".. for this long; then the configured stiffness again.",
                                  .low = 0.0,
                                  .high = 600.0};
inline const KeySpec kMargin{.key = "margin",
                             .range = KeyRange::kInRange,
                             .default_value = kDefaults.margin,
                             .meaning = "The fixture goes to this × the predicted limit at the measured delay.",
                             .low = 0.05,
                             .high = 1.0};
inline const KeySpec kMaxForceRate{.key = "max_force_rate_N_per_s",
                                   .unit = "N/s",
                                   .range = KeyRange::kPositive,
                                   .default_value = kDefaults.max_force_rate_N_per_s,
                                   .meaning =
                                       "The ramp's force rate at max_penetration_m: a stiffness change of Δk "
                                       "ramps over Δk × max_penetration_m / this.",
                                   .low = 0.0,
                                   .high = 0.0};
inline const KeySpec kMaxPenetration{.key = "max_penetration_m",
                                     .unit = "m",
                                     .range = KeyRange::kPositive,
                                     .default_value = kDefaults.max_penetration_m,
                                     .meaning = "The deepest penetration the ramp's force rate is bounded at.",
                                     .low = 0.0,
                                     .high = 0.0};
inline const KeySpec kOnUnstable{.key = "on_unstable",
                                 .type = KeyType::kChoice,
                                 .meaning =
                                     "When no fixture is stable at the measured delay (the coupling itself is "
                                     "not): `event` logs it and changes nothing; `decouple` also presses the "
                                     "command clutch (released by `teleop-ctl clutch off`); `passivity` switches "
                                     "the passivity controller on (`observer`, passive from the switch on, any "
                                     "delay) where `passivity.mode` is `off` (with `passivity.max_damping_Ns_per_m` "
                                     "given), and back off when the coupling is stable at the measured delay "
                                     "again.",
                                 .choices = {"event", "decouple", "passivity"},
                                 .default_choice = static_cast<int>(kDefaults.on_unstable)};

/// In the order of docs/configuration.md's table.
inline const std::array<const KeySpec*, 10> kAll = {&kEnabled,        &kWindow,      &kPercentile, &kTriggerRatio,
                                                    &kRecoverRatio,   &kRecoverHold, &kMargin,     &kMaxForceRate,
                                                    &kMaxPenetration, &kOnUnstable};

}  // namespace teleop::config::delay_recheck_keys
