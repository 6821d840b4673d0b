#include "teleop/dds/dashboard_messages.hpp"

#include <fmt/format.h>

#include <cmath>

#include "teleop/dds/topic_names.hpp"

namespace teleop::dds {

namespace {

/// A number for JSON: null for NaN and infinities (JSON has neither).
std::string Num(double v) { return std::isfinite(v) ? fmt::format("{}", v) : "null"; }

/// The length of the valid UTF-8 sequence at text[i] (1..4), or 0 when the bytes there are not one (a stray
/// continuation byte, a truncated sequence, an overlong form, a surrogate, or beyond U+10FFFF; RFC 3629 section 4).
std::size_t Utf8SequenceLength(std::string_view text, std::size_t i, std::uint32_t& code_point) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b0 = byte(i);
  std::size_t n = 0;
  std::uint32_t min = 0;
  if (b0 < 0x80) {
    code_point = b0;
    return 1;
  }
  if ((b0 & 0xE0U) == 0xC0U) {
    n = 2;
    min = 0x80;
    code_point = b0 & 0x1FU;
  } else if ((b0 & 0xF0U) == 0xE0U) {
    n = 3;
    min = 0x800;
    code_point = b0 & 0x0FU;
  } else if ((b0 & 0xF8U) == 0xF0U) {
    n = 4;
    min = 0x10000;
    code_point = b0 & 0x07U;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    const unsigned char b = byte(i + k);
    if ((b & 0xC0U) != 0x80U) return 0;
    code_point = (code_point << 6U) | (b & 0x3FU);
  }
  if (code_point < min || code_point > 0x10FFFF || (code_point >= 0xD800 && code_point <= 0xDFFF)) return 0;
  return n;
}

std::string Axes(const StateTrace::Axes& values, std::uint8_t dof) {
  std::string out = "[";
  for (std::size_t i = 0; i < dof && i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += Num(values[i]);
  }
  out += ']';
  return out;
}

}  // namespace

std::string DashboardJsonString(std::string_view text) {
  std::string out = "\"";
  out.reserve(text.size() + 2);
  std::size_t i = 0;
  while (i < text.size()) {
    std::uint32_t cp = 0;
    const std::size_t n = Utf8SequenceLength(text, i, cp);
    if (n == 0) {
      out += "\\ufffd";  // not UTF-8: the replacement character, one per offending byte
      ++i;
      continue;
    }
    if (n > 1) {
      if (cp == 0x2028 || cp == 0x2029) {
        out += fmt::format("\\u{:04x}", cp);
      } else {
        out.append(text.substr(i, n));
      }
      i += n;
      continue;
    }
    const char c = text[i++];
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      case '<':
      case '>':
      case '&':
      case '\'':
        out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) {
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(c)));
        } else {
          out += c;
        }
    }
  }
  out += '"';
  return out;
}

std::string EncodeHello(double t_s) {
  return fmt::format(R"({{"type":"hello","version":{},"t_s":{}}})", kDashboardProtocolVersion, Num(t_s));
}

std::string EncodeProcesses(const std::vector<ProcessView>& views, double t_s) {
  std::string out = fmt::format(R"({{"type":"processes","t_s":{},"processes":[)", Num(t_s));
  bool first = true;
  for (const ProcessView& v : views) {
    if (!first) out += ',';
    first = false;
    const bool state = v.have_state;
    const auto known = [state](double x) { return state ? x : std::nan(""); };
    out += fmt::format(
        R"({{"pair":{},"role":{},"status":{},"engagement":{},"clutch":{},"age_s":{},"cycle":{},"time_s":{},)"
        R"("rate_hz":{},)"
        R"("achieved_rate_hz":{},"loss_fraction":{},"rtt_ms":{},"device_faults":{},"watchdog_trips":{},)"
        R"("packets_lost":{},"tracking_error_m":{},"fixture_penetration_m":{},"last_event":{},"stop_reason":{}}})",
        DashboardJsonString(v.pair), DashboardJsonString(v.role), DashboardJsonString(ToString(v.status)),
        state ? DashboardJsonString(ToString(v.engagement)) : std::string("null"),
        state ? DashboardJsonString(ClutchText(v.clutch)) : std::string("null"), Num(v.age_s), v.cycle,
        Num(known(v.time_s)), Num(known(v.rate_hz)), Num(known(v.achieved_rate_hz)), Num(known(v.loss_fraction)),
        Num(known(v.rtt_ms)), v.device_faults, v.watchdog_trips, v.packets_lost, Num(known(v.tracking_error_m)),
        Num(known(v.fixture_penetration_m)), DashboardJsonString(v.last_event), DashboardJsonString(v.stop_reason));
  }
  out += "]}";
  return out;
}

std::string EncodeState(const StateTrace& t, double t_s) {
  std::string out = fmt::format(
      R"({{"type":"state","t_s":{},"pair":{},"role":{},"cycle":{},"time_s":{},"engagement":{},"device_faults":{},)"
      R"("dof":{},"position_m":{},"peer_position_m":{},"force_sensor_N":{},"command_N":{},)"
      R"("fixture_penetration_m":{},"tracking_error_m":{},"rtt_ms":{})",
      Num(t_s), DashboardJsonString(t.pair), DashboardJsonString(t.role), t.cycle, Num(t.time_s),
      DashboardJsonString(ToString(t.engagement)), t.device_faults, t.dof, Axes(t.position_m, t.dof),
      Axes(t.peer_position_m, t.dof), Axes(t.force_sensor_N, t.dof), Axes(t.command_N, t.dof),
      Num(t.fixture_penetration_m), Num(t.tracking_error_m), Num(t.rtt_ms));
  if (t.clutched) out += *t.clutched ? R"(,"clutch":"clutched")" : R"(,"clutch":"released")";
  out += '}';
  return out;
}

std::string EncodeEvent(std::string_view pair, std::string_view role, std::string_view kind_name, std::uint64_t cycle,
                        double value, double t_s) {
  return fmt::format(R"({{"type":"event","t_s":{},"pair":{},"role":{},"kind":{},"cycle":{},"value":{}}})", Num(t_s),
                     DashboardJsonString(pair), DashboardJsonString(role), DashboardJsonString(kind_name), cycle,
                     Num(value));
}

std::optional<std::string> ParseDashboardRequest(std::string_view message) {
  constexpr std::string_view kSubscribe = "subscribe";
  if (message.substr(0, kSubscribe.size()) != kSubscribe) return std::nullopt;
  message.remove_prefix(kSubscribe.size());
  if (message.empty()) return std::string();
  if (message.front() != ' ') return std::nullopt;
  message.remove_prefix(1);
  if (!IsValidNameToken(message)) return std::nullopt;
  return std::string(message);
}

}  // namespace teleop::dds
