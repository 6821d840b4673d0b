#include "teleop/dds/dashboard_messages.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "teleop/dds/topic_names.hpp"
#include "teleop/json_text.hpp"

namespace teleop::dds {

namespace {

/// A number for JSON: null for NaN and infinities (JSON has neither).
std::string Num(double v) { return std::isfinite(v) ? fmt::format("{}", v) : "null"; }

/// A JSON array of the first `count` of `values` (the axes of the DOF, or the joints).
template <std::size_t N>
std::string List(const std::array<double, N>& values, std::uint8_t count) {
  std::string out = "[";
  for (std::size_t i = 0; i < count && i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += Num(values[i]);
  }
  out += ']';
  return out;
}

}  // namespace

std::string EncodeHello(double t_s, double history_s, bool commands) {
  return fmt::format(R"({{"type":"hello","version":{},"t_s":{},"history_s":{},"commands":{}}})",
                     kDashboardProtocolVersion, Num(t_s), Num(history_s), commands ? "true" : "false");
}

std::string EncodeCommand(std::string_view pair, std::string_view role, std::string_view text, std::string_view from,
                          std::string_view reply, double t_s) {
  return fmt::format(R"({{"type":"command","t_s":{},"pair":{},"role":{},"text":{},"from":{},"reply":{}}})", Num(t_s),
                     JsonString(pair), JsonString(role), JsonString(text), JsonString(from), JsonString(reply));
}

namespace {

std::string ProcessRow(const ProcessView& v) {
  const bool state = v.have_state;
  const auto known = [state](double x) { return state ? x : std::nan(""); };
  return fmt::format(
      R"({{"pair":{},"role":{},"status":{},"engagement":{},"clutch":{},"age_s":{},"cycle":{},"time_s":{},)"
      R"("rate_hz":{},)"
      R"("achieved_rate_hz":{},"loss_fraction":{},"rtt_ms":{},"device_faults":{},"watchdog_trips":{},)"
      R"("packets_lost":{},"tracking_error_m":{},"fixture_penetration_m":{},"last_event":{},"stop_reason":{}}})",
      JsonString(v.pair), JsonString(v.role), JsonString(ToString(v.status)),
      state ? JsonString(ToString(v.engagement)) : std::string("null"),
      state ? JsonString(ClutchText(v.clutch)) : std::string("null"), Num(v.age_s), v.cycle, Num(known(v.time_s)),
      Num(known(v.rate_hz)), Num(known(v.achieved_rate_hz)), Num(known(v.loss_fraction)), Num(known(v.rtt_ms)),
      v.device_faults, v.watchdog_trips, v.packets_lost, Num(known(v.tracking_error_m)),
      Num(known(v.fixture_penetration_m)), JsonString(v.last_event), JsonString(v.stop_reason));
}

}  // namespace

std::string EncodeProcesses(const std::vector<ProcessView>& views, double t_s, std::size_t offset, std::size_t rows,
                            std::string_view pair) {
  const std::size_t first = std::min(offset, views.size());
  const std::size_t last = first + std::min(rows, views.size() - first);
  std::string out = fmt::format(R"({{"type":"processes","t_s":{},"total":{},"offset":{},"processes":[)", Num(t_s),
                                views.size(), first);
  for (std::size_t i = first; i < last; ++i) {
    if (i > first) out += ',';
    out += ProcessRow(views[i]);
  }
  out += R"(],"chosen":[)";
  bool any = false;
  for (const ProcessView& v : views) {
    if (pair.empty() || v.pair != pair) continue;
    if (any) out += ',';
    any = true;
    out += ProcessRow(v);
  }
  out += "]}";
  return out;
}

std::string EncodeState(const StateTrace& t, double t_s) {
  std::string out = fmt::format(
      R"({{"type":"state","t_s":{},"pair":{},"role":{},"cycle":{},"time_s":{},"engagement":{},"device_faults":{},)"
      R"("dof":{},"position_m":{},"peer_position_m":{},"force_sensor_N":{},"command_N":{},)"
      R"("fixture_penetration_m":{},"tracking_error_m":{},"rtt_ms":{},)"
      R"("fixture_stiffness_N_per_m":{},"fixture_limit_N_per_m":{},"joints":{},"joint_position_rad":{},)"
      R"("joint_torque_Nm":{})",
      Num(t_s), JsonString(t.pair), JsonString(t.role), t.cycle, Num(t.time_s), JsonString(ToString(t.engagement)),
      t.device_faults, t.dof, List(t.position_m, t.dof), List(t.peer_position_m, t.dof), List(t.force_sensor_N, t.dof),
      List(t.command_N, t.dof), Num(t.fixture_penetration_m), Num(t.tracking_error_m), Num(t.rtt_ms),
      Num(t.fixture_stiffness_N_per_m), Num(t.fixture_limit_N_per_m), t.joints, List(t.joint_position_rad, t.joints),
      List(t.joint_torque_Nm, t.joints));
  if (t.clutched) out += *t.clutched ? R"(,"clutch":"clutched")" : R"(,"clutch":"released")";
  out += '}';
  return out;
}

std::string EncodeEvent(std::string_view pair, std::string_view role, std::string_view kind_name, std::uint64_t cycle,
                        double value, double t_s) {
  return fmt::format(R"({{"type":"event","t_s":{},"pair":{},"role":{},"kind":{},"cycle":{},"value":{}}})", Num(t_s),
                     JsonString(pair), JsonString(role), JsonString(kind_name), cycle, Num(value));
}

std::optional<DashboardRequest> ParseDashboardRequest(std::string_view message) {
  constexpr std::string_view kSubscribe = "subscribe";
  constexpr std::string_view kTable = "table ";
  constexpr std::string_view kCommand = "command ";
  DashboardRequest r;
  if (message.substr(0, kCommand.size()) == kCommand) {
    message.remove_prefix(kCommand.size());
    const std::size_t token_end = message.find(' ');
    if (token_end != 64) return std::nullopt;
    r.token = std::string(message.substr(0, token_end));
    if (r.token.find_first_not_of("0123456789abcdef") != std::string::npos) return std::nullopt;
    message.remove_prefix(token_end + 1);
    const std::size_t role_end = message.find(' ');
    if (role_end == std::string_view::npos) return std::nullopt;
    r.role = std::string(message.substr(0, role_end));
    if (r.role != "master" && r.role != "slave") return std::nullopt;
    message.remove_prefix(role_end + 1);
    if (message.empty() || message.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 "
                                                     ".:_+-") != std::string_view::npos)
      return std::nullopt;
    const std::string_view verb = message.substr(0, message.find(' '));
    if (std::find(std::begin(kDashboardCommands), std::end(kDashboardCommands), verb) == std::end(kDashboardCommands))
      return std::nullopt;
    r.kind = DashboardRequest::Kind::kCommand;
    r.line = std::string(message);
    return r;
  }
  if (message.substr(0, kTable.size()) == kTable) {
    message.remove_prefix(kTable.size());
    if (message.empty() || message.size() > 9 || message.find_first_not_of("0123456789") != std::string_view::npos)
      return std::nullopt;
    r.kind = DashboardRequest::Kind::kTable;
    r.offset = static_cast<std::size_t>(std::stoul(std::string(message)));
    return r;
  }
  if (message.substr(0, kSubscribe.size()) != kSubscribe) return std::nullopt;
  message.remove_prefix(kSubscribe.size());
  if (message.empty()) return r;
  if (message.front() != ' ') return std::nullopt;
  message.remove_prefix(1);
  if (!IsValidNameToken(message)) return std::nullopt;
  r.pair = std::string(message);
  return r;
}

}  // namespace teleop::dds
