#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/dds/process_view.hpp"
#include "teleop/dds/state_trace.hpp"

namespace teleop::dds {

/// The messages of teleop-supervise's dashboard WebSocket (docs/dds.md, "The dashboard"): one JSON object per text
/// frame, with "type" first. Every string that came over DDS goes through teleop::JsonString (teleop/json_text.hpp).
/// `t_s` is the supervisor's clock (seconds since it started), the common time axis of all traces.
inline constexpr int kDashboardProtocolVersion = 2;

/// {"type":"hello","version":2,"t_s":...,"history_s":...}: the first message on a new connection; history_s is how
/// many seconds of a pair's states and events the server sends when the page subscribes to it.
std::string EncodeHello(double t_s, double history_s = 0.0, bool commands = false);
/// {"type":"command","t_s":...,"pair":...,"role":...,"text":...,"from":...,"reply":...}: a command a page sent
/// (teleop-supervise --allow-commands), who sent it and the process's reply; to every page of the pair.
std::string EncodeCommand(std::string_view pair, std::string_view role, std::string_view text, std::string_view from,
                          std::string_view reply, double t_s);
/// {"type":"processes","t_s":...,"total":N,"offset":K,"processes":[{pair, role, status, engagement, age_s, rate_hz,
/// ...}],"chosen":[...]}: rows K..K+rows-1 of the table of every process on the domain (unknown numbers are null),
/// and the rows of `pair` (the page's own pair, wherever it is in the table; none for "").
std::string EncodeProcesses(const std::vector<ProcessView>& views, double t_s, std::size_t offset = 0,
                            std::size_t rows = 50, std::string_view pair = {});
/// {"type":"state","t_s":...,"pair":...,"role":...,"position_m":[...],...}: one State sample's traces; "clutch"
/// ("clutched"/"released") only when the sample carries one; "fixture_limit_N_per_m" null when the process computes
/// no limit; "joints" and that many entries in "joint_position_rad" and "joint_torque_Nm" (0 and [] on a Cartesian
/// device).
std::string EncodeState(const StateTrace& trace, double t_s);
/// {"type":"event","t_s":...,"pair":...,"role":...,"kind":...,"cycle":...,"value":...}.
std::string EncodeEvent(std::string_view pair, std::string_view role, std::string_view kind_name, std::uint64_t cycle,
                        double value, double t_s);

/// A message from the page.
struct DashboardRequest {
  enum class Kind {
    kSubscribe,  ///< "subscribe <pair>": the pair whose traces it wants (a valid pair name, docs/dds.md), or none.
    kTable,      ///< "table <offset>": the rows of the process table from `offset` on.
    kCommand,    ///< "command <token> <role> <line>": a command for the subscribed pair's process `role`.
  };
  Kind kind = Kind::kSubscribe;
  std::string pair;        ///< kSubscribe: "" for none.
  std::size_t offset = 0;  ///< kTable.
  std::string token;       ///< kCommand: as sent (checked by the server).
  std::string role;        ///< kCommand: master or slave.
  std::string line;        ///< kCommand: one of kDashboardCommands and its arguments (safe characters only).
};
/// The commands a page may send (those of teleop-ctl that change the coupling, docs/clutch.md); the process's command
/// channel applies its stability gate and bounded rates to each as to teleop-ctl's.
inline constexpr std::string_view kDashboardCommands[] = {"clutch", "fixture", "fixture-stiffness", "fixture-plane",
                                                          "gain"};
/// Parses "subscribe", "subscribe <pair>", "table <offset>" (at most 9 digits) or "command <token> <role> <line>"
/// (token 64 hex digits, role master|slave, line one of kDashboardCommands then letters, digits, space, . : _ + -);
/// nullopt for anything else.
std::optional<DashboardRequest> ParseDashboardRequest(std::string_view message);

}  // namespace teleop::dds
