#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/dds/process_view.hpp"
#include "teleop/dds/state_trace.hpp"

namespace teleop::dds {

/// The messages of teleop-supervise's dashboard WebSocket (docs/dds.md, "The dashboard"): one JSON object per text
/// frame, with "type" first. Every string that came over DDS goes through DashboardJsonString. `t_s` is the
/// supervisor's clock (seconds since it started), the common time axis of all traces.
inline constexpr int kDashboardProtocolVersion = 1;

/// `text` as a JSON string literal (quotes included) safe for a WebSocket text frame and for a page: quote,
/// backslash and control characters escaped as in teleop::JsonString, also <, >, &, ' and U+2028/U+2029 as \uXXXX
/// (so the text is inert even where it ends up inside HTML or a script), and every byte that is not part of valid
/// UTF-8 replaced by U+FFFD (a text frame must be valid UTF-8: a browser drops the connection otherwise).
std::string DashboardJsonString(std::string_view text);

/// {"type":"hello","version":1,"t_s":...}: the first message on a new connection.
std::string EncodeHello(double t_s);
/// {"type":"processes","t_s":...,"processes":[{pair, role, status, engagement, age_s, rate_hz, ...}]}: the table
/// of every process on the domain (unknown numbers are null).
std::string EncodeProcesses(const std::vector<ProcessView>& views, double t_s);
/// {"type":"state","t_s":...,"pair":...,"role":...,"position_m":[...],...}: one State sample's traces; "clutch"
/// ("clutched"/"released") only when the sample carries one.
std::string EncodeState(const StateTrace& trace, double t_s);
/// {"type":"event","t_s":...,"pair":...,"role":...,"kind":...,"cycle":...,"value":...}.
std::string EncodeEvent(std::string_view pair, std::string_view role, std::string_view kind_name, std::uint64_t cycle,
                        double value, double t_s);

/// A message from the page: "subscribe <pair>" (the pair whose traces it wants; a valid pair name, docs/dds.md) or
/// "subscribe" alone (none). Returns the pair ("" for none), or nullopt for anything else.
std::optional<std::string> ParseDashboardRequest(std::string_view message);

}  // namespace teleop::dds
