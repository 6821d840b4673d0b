#pragma once

// Private to the config library: one reader per section of a process config (docs/configuration.md), each in its
// own file (link_section.cpp, law_section.cpp, device_section.cpp, stability_section.cpp, telemetry_section.cpp);
// yaml_config.cpp reads the top level and calls them. Each lists its allowed keys (anything else is an error), reads
// its required and optional keys and checks ranges, failing with "FILE:LINE:COL: key 'a.b': reason".

#include <string>

#include "teleop/config/process_config.hpp"
#include "teleop/config/yaml_reader.hpp"

namespace teleop::config::sections {

void ParseLink(const Field& f, Role role, double rate_hz, int dof, link::LinkConfig& link);
/// `link.emulate` (link_emulate_section.cpp).
void ParseLinkEmulate(const Field& f, double rate_hz, link::LinkConfig::Emulation& emulate);
/// `link.security` (security_section.cpp), required: a config without it is refused with how to make a key.
void ParseSecurity(const Map& link, const std::string& transport, int dof, transport::LinkSecurityConfig& security);
void ParseLaw(const Field& f, double rate_hz, control::ThreeChannelLaw::Config& law);
void ParseFixture(const Field& f, int dof, control::ForbiddenRegionFixture::Config& fixture);
/// `device:`: the backend's name and its own section, read by the backend's registered reader.
void ParseDevice(const Field& f, Role role, int dof, device::DeviceConfig& device);
void ParseTelemetry(const Field& f, TelemetryConfig& telemetry);
void ParseStability(const Field& f, int dof, StabilityConfig& stability);
/// `passivity:` (read after `link:`: energy_exchange is refused over CAN).
void ParsePassivity(const Field& f, int dof, const link::LinkConfig& link,
                    control::PassivityController::Config& passivity);
void ParseEngagement(const Field& f, EngagementConfig& engagement);
/// `safety:`; `role` decides the allowed reactions (the default is set before, by DefaultReaction).
void ParseSafety(const Field& f, Role role, SafetyConfig& safety);
Reaction DefaultReaction(Role role) noexcept;

}  // namespace teleop::config::sections
