// teleop-drive: commissioning of CiA 402 drives on SocketCAN or the emulated bus (docs/cia402.md, "Bring-up with
// teleop-drive").
//
//   teleop-drive [--can can0 | --bus-port 47300] scan [--from 1 --to 127 --timeout-ms 20]
//   teleop-drive ... info NODE
//   teleop-drive ... sdo read NODE INDEX SUB [--type u8|u16|u32|i8|i16|i32|string]
//   teleop-drive ... sdo write NODE INDEX SUB VALUE [--type ...]
//   teleop-drive ... enable NODE --mode torque|velocity|position --limit L [--for S]
//   teleop-drive ... jog NODE (--torque T | --velocity V | --position P) --limit L --for S
//   teleop-drive ... fault-reset NODE
//   teleop-drive ... record NODE --csv FILE --for S [--mode ...]
//   teleop-drive ... simulate --node N [--node M ...]     # simulated drives on the bus (the walkthrough, tests)
//
// enable, jog and record run the cycle (RPDO, SYNC, TPDOs) at --period-ms; SIGINT/SIGTERM (the deadman) and the end of
// --for stop the motor: target 0 (or the position held), Disable Operation, Shutdown, NMT pre-operational.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "teleop/cli_help.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/canopen_sdo_client.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/cia402_eds.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/version.hpp"

namespace {

using teleop::Error;
namespace fb = teleop::fieldbus;
namespace canopen = teleop::fieldbus::canopen;
namespace cia402 = teleop::fieldbus::cia402;

std::atomic<bool> g_stop{false};
void OnSignal(int /*signal*/) { g_stop = true; }

std::uint64_t NowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
          .count());
}

struct Options {
  std::string can_interface;
  std::string bus_host = "127.0.0.1";
  int bus_port = 0;
  double sdo_timeout_ms = 50.0;
  int sdo_retries = 2;
  double period_ms = 2.0;
  double rated_torque_Nm = 1.0;
  double position_rad_per_count = 1.0 / 4096.0;
  double velocity_rad_per_s_per_unit = 1.0 / 4096.0;
  std::string eds_file;
  double stale_ms = 0.0;  ///< 0: ten cycles, at least 10 ms
  double heartbeat_timeout_ms = 200.0;
  /// The drive's consumer of the tool's heartbeat (0x1016:01, 0: off): a tool that dies (SIGKILL, a crash, a cable)
  /// cannot run its deadman, so the drive stops itself this long after the tool's last heartbeat.
  double drive_consumer_timeout_ms = 500.0;
};

fb::CanPortConfig PortConfig(const Options& o) {
  fb::CanPortConfig c;
  if (o.bus_port > 0) {
    c.medium = teleop::transport::CanMedium::kEmulatedBus;
    c.emulated_bus_host = o.bus_host;
    c.emulated_bus_port = static_cast<std::uint16_t>(o.bus_port);
  } else {
    c.medium = teleop::transport::CanMedium::kSocketCan;
    c.interface_name = o.can_interface.empty() ? "can0" : o.can_interface;
  }
  return c;
}

std::uint8_t NodeId(int node) {
  if (node < 1 || node > 127) throw Error(fmt::format("node-ID {} is not 1..127", node));
  return static_cast<std::uint8_t>(node);
}

canopen::SdoClientConfig SdoConfig(const Options& o, int retries) {
  canopen::SdoClientConfig c;
  c.timeout_ms = o.sdo_timeout_ms;
  c.retries = retries;
  c.backoff_initial_ms = 5.0;
  c.backoff_max_ms = 50.0;
  return c;
}

/// A port that sees every frame (the tool is a bus analyser as much as a master).
std::unique_ptr<fb::CanPort> OpenAll(const Options& o) {
  return fb::OpenCanPort(PortConfig(o), teleop::transport::CanReceiveOptions::Everything());
}

fb::Cia402DriveConfig DriveConfig(const Options& o, std::uint8_t node, fb::Cia402Mode mode, double limit) {
  fb::Cia402DriveConfig c;
  c.node_id = node;
  c.mode = mode;
  c.rpdos = fb::Cia402DriveConfig::DefaultRpdos(mode);
  c.sdo = SdoConfig(o, o.sdo_retries);
  c.cycle_period_s = o.period_ms * 1e-3;
  c.scaling.rated_torque_Nm = o.rated_torque_Nm;
  c.scaling.position_rad_per_count = o.position_rad_per_count;
  c.scaling.velocity_rad_per_s_per_unit = o.velocity_rad_per_s_per_unit;
  c.drive_heartbeat_period_ms = 50.0;
  c.heartbeat_timeout_ms = o.heartbeat_timeout_ms;
  c.drive_consumer_timeout_ms = o.drive_consumer_timeout_ms;
  c.stale_after_ms = o.stale_ms > 0.0 ? o.stale_ms : std::max(10.0, 10.0 * o.period_ms);
  c.eds_file = o.eds_file;
  if (mode == fb::Cia402Mode::kCyclicSynchronousTorque) {
    c.max_torque_Nm = limit;
  } else {
    c.max_velocity_rad_per_s = limit;
  }
  fb::ApplyEds(c);
  return c;
}

// ---- scan ----
int Scan(const Options& o, int from, int to, double timeout_ms) {
  auto port = OpenAll(o);
  // NMT states from the heartbeats heard in 300 ms (a node without heartbeat shows '-').
  std::vector<int> nmt(128, -1);
  const std::uint64_t listen_end = NowNs() + 300'000'000;
  while (NowNs() < listen_end && !g_stop) {
    teleop::proto::can::CanFrame f{};
    while (port->Read(f)) {
      std::uint8_t node = 0;
      canopen::NmtState state{};
      if (canopen::DecodeHeartbeat(f, node, state)) nmt[node] = static_cast<int>(state);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  std::printf("%-5s %-16s %-10s %-10s %-10s %-10s %-10s %s\n", "node", "nmt", "device", "vendor", "product", "revision",
              "serial", "profile");
  int found = 0;
  for (int n = from; n <= to && !g_stop; ++n) {
    canopen::SdoClientConfig sc = SdoConfig(o, 0);
    sc.timeout_ms = timeout_ms;
    canopen::SdoClient sdo(*port, static_cast<std::uint8_t>(n), sc, fb::Timebase::Steady(),
                           [&](const teleop::proto::can::CanFrame& f) {
                             std::uint8_t node = 0;
                             canopen::NmtState state{};
                             if (canopen::DecodeHeartbeat(f, node, state)) nmt[node] = static_cast<int>(state);
                           });
    std::uint32_t device_type = 0;
    try {
      device_type = sdo.Upload(cia402::obj301::kDeviceType, 0, 4);
    } catch (const canopen::SdoAbortError& e) {
      std::printf("%-5d answers, 0x1000 aborted: %s\n", n, e.what());
      ++found;
      continue;
    } catch (const Error&) {
      continue;  // no answer within the timeout: no node
    }
    ++found;
    std::uint32_t id[4] = {0, 0, 0, 0};
    for (std::uint8_t s = 1; s <= 4; ++s) {
      try {
        id[s - 1] = sdo.Upload(cia402::obj301::kIdentity, s, 4);
      } catch (const Error&) {
      }
    }
    const char* state = nmt[n] < 0 ? "-" : canopen::ToString(static_cast<canopen::NmtState>(nmt[n]));
    std::printf("%-5d %-16s 0x%08X 0x%08X 0x%08X 0x%08X 0x%08X %s\n", n, state, device_type, id[0], id[1], id[2], id[3],
                (device_type & 0xFFFFu) == cia402::kDeviceProfile402 ? "CiA 402 drive" : "");
  }
  std::printf("%d node%s found in %d..%d (timeout %g ms per node)\n", found, found == 1 ? "" : "s", from, to,
              timeout_ms);
  return found > 0 ? 0 : 1;
}

// ---- info ----
int Info(const Options& o, int node_arg) {
  const std::uint8_t node = NodeId(node_arg);
  auto port = OpenAll(o);
  fb::Cia402DriveConfig c;
  c.node_id = node;
  c.sdo = SdoConfig(o, o.sdo_retries);
  fb::Cia402Drive drive(c, *port);
  const fb::Cia402DeviceInfo& info = drive.ReadDeviceInfo();
  auto& sdo = drive.sdo();
  std::printf("node %d\n", node);
  std::printf("  device type        0x%08X%s\n", info.device_type,
              (info.device_type & 0xFFFFu) == cia402::kDeviceProfile402 ? " (CiA 402 drive)" : "");
  if (info.identity_present) {
    std::printf("  identity           vendor 0x%08X product 0x%08X revision 0x%08X serial 0x%08X\n", info.vendor_id,
                info.product_code, info.revision, info.serial);
  }
  std::printf("  device name        %s\n", info.device_name_present ? info.device_name.c_str() : "-");
  std::printf("  hardware version   %s\n", info.hardware_version_present ? info.hardware_version.c_str() : "-");
  std::printf("  software version   %s\n", info.software_version_present ? info.software_version.c_str() : "-");
  if (info.supported_modes_present) {
    std::string modes;
    for (int m : {8, 9, 10}) {
      if ((info.supported_modes & cia402::SupportedModeBit(static_cast<std::int8_t>(m))) != 0) {
        fb::Cia402Mode mode{};
        (void)fb::ParseCia402Mode(std::to_string(m), mode);
        modes += fmt::format("{}{} ({})", modes.empty() ? "" : ", ", m, fb::ToString(mode));
      }
    }
    std::printf("  supported modes    0x%08X: %s\n", info.supported_modes,
                modes.empty() ? "no cyclic mode" : modes.c_str());
  }
  if ((info.device_type & 0xFFFFu) == cia402::kDeviceProfile402) {
    const auto sw = static_cast<std::uint16_t>(sdo.Upload(cia402::obj::kStatusword, 0, 2));
    const auto mode = static_cast<std::int8_t>(sdo.Upload(cia402::obj::kModesOfOperationDisplay, 0, 1));
    const auto code = static_cast<std::uint16_t>(sdo.Upload(cia402::obj::kErrorCode, 0, 2));
    const auto reg = static_cast<std::uint8_t>(sdo.Upload(cia402::obj301::kErrorRegister, 0, 1));
    std::printf("  state              %s (statusword 0x%04X)\n", cia402::ToString(cia402::DecodeStatusword(sw)), sw);
    std::printf("  mode display       %d\n", mode);
    std::printf("  error              0x%04X %s, error register 0x%02X\n", code, canopen::DescribeEmergencyCode(code),
                reg);
  }
  if (info.error_history_present) {
    std::printf("  error history      %zu entr%s\n", info.error_history.size(),
                info.error_history.size() == 1 ? "y" : "ies");
    for (std::size_t k = 0; k < info.error_history.size(); ++k) {
      const std::uint32_t e = info.error_history[k];
      std::printf("    %zu: 0x%04X %s (info 0x%04X)\n", k + 1, e & 0xFFFFu,
                  canopen::DescribeEmergencyCode(static_cast<std::uint16_t>(e & 0xFFFFu)), e >> 16);
    }
  }
  return 0;
}

// ---- sdo ----
std::uint8_t TypeSize(const std::string& type) {
  if (type == "u8" || type == "i8") return 1;
  if (type == "u16" || type == "i16") return 2;
  if (type == "u32" || type == "i32") return 4;
  return 0;
}

int Sdo(const Options& o, const std::string& op, int node_arg, const std::string& index_text,
        const std::string& sub_text, const std::string& value_text, const std::string& type) {
  const std::uint8_t node = NodeId(node_arg);
  std::uint32_t index = 0;
  std::uint32_t sub = 0;
  if (!canopen::ParseEdsValue(index_text, 0, index) || index > 0xFFFF) {
    throw Error(fmt::format("INDEX '{}' is not a 16-bit number (0x6041)", index_text));
  }
  if (!canopen::ParseEdsValue(sub_text, 0, sub) || sub > 0xFF) {
    throw Error(fmt::format("SUB '{}' is not an 8-bit number", sub_text));
  }
  if (type != "string" && TypeSize(type) == 0)
    throw Error(fmt::format("--type {}: u8|u16|u32|i8|i16|i32|string", type));
  auto port = OpenAll(o);
  canopen::SdoClient sdo(*port, node, SdoConfig(o, o.sdo_retries), fb::Timebase::Steady());
  const auto i = static_cast<std::uint16_t>(index);
  const auto s = static_cast<std::uint8_t>(sub);
  if (op == "read") {
    if (type == "string") {
      std::printf("%s\n", sdo.UploadString(i, s).c_str());
      return 0;
    }
    const std::uint8_t size = TypeSize(type);
    const std::uint32_t v = sdo.Upload(i, s, size);
    std::int64_t signed_value = v;
    if (type[0] == 'i') signed_value = canopen::SignExtend(v, 8 * size);
    std::printf("%s = 0x%0*X (%lld)\n", canopen::FormatObject(i, s).c_str(), 2 * size, v,
                static_cast<long long>(signed_value));
    return 0;
  }
  if (op != "write") throw Error(fmt::format("sdo {}: read or write", op));
  if (value_text.empty()) throw Error("sdo write: VALUE is missing");
  if (type == "string") {
    const std::vector<std::uint8_t> bytes(value_text.begin(), value_text.end());
    sdo.DownloadBytes(i, s, bytes);
  } else {
    std::uint32_t v = 0;
    if (!canopen::ParseEdsValue(value_text, 0, v)) throw Error(fmt::format("VALUE '{}' is not a number", value_text));
    sdo.Download(i, s, v, TypeSize(type));
  }
  std::printf("%s written\n", canopen::FormatObject(i, s).c_str());
  return 0;
}

// ---- the cycle: enable, jog, record ----
struct Run {
  double for_s = 0.0;     ///< 0: until interrupted.
  double setpoint = 0.0;  ///< In the mode's unit (position: relative to the start).
  bool relative = false;  ///< Position: setpoint added to the position at enable.
  std::string csv;        ///< Record every cycle here.
};

int Cycle(const Options& o, int node_arg, fb::Cia402Mode mode, double limit, const Run& run) {
  const std::uint8_t node = NodeId(node_arg);
  if (!(limit > 0.0) || !std::isfinite(limit)) throw Error("--limit must be > 0");
  fb::Cia402DriveConfig c = DriveConfig(o, node, mode, limit);
  auto port = fb::OpenCanPort(PortConfig(o), fb::Cia402Drive::ReceiveOptions(c));
  fb::Cia402Drive drive(c, *port);
  std::FILE* csv = nullptr;
  if (!run.csv.empty()) {
    csv = std::fopen(run.csv.c_str(), "w");
    if (csv == nullptr) throw Error(fmt::format("--csv {}: cannot open for writing", run.csv));
    std::fprintf(csv, "t_s,status,state,statusword,position_rad,velocity_rad_per_s,torque_Nm,command\n");
  }
  // The tool's heartbeat stops when it exits: the drive's consumer is switched off again after a clean stop, so
  // only a tool that died leaves it to fire.
  const auto consumer_off = [&] {
    if (c.drive_consumer_timeout_ms <= 0.0) return;
    try {
      drive.sdo().Download(cia402::obj301::kConsumerHeartbeatTime, 1, 0, 4);
    } catch (const Error& e) {
      std::fprintf(stderr, "teleop-drive: node %d: switching the drive's heartbeat consumer off: %s\n", node, e.what());
    }
  };
  bool configured = false;
  try {
    drive.Configure();  // a failed configure undoes its own writes (the heartbeat consumer 0x1016:01)
    configured = true;
    drive.Activate();
  } catch (const Error&) {
    if (configured) {
      (void)drive.Deactivate();  // a half-done enable is undone: nothing is left switched on
      consumer_off();
    }
    throw;
  }
  std::printf("node %d: Operation Enabled, %s, limit %g\n", node, fb::ToString(mode), limit);
  std::fflush(stdout);
  const double start_position = drive.position_target_rad();
  const double target = run.relative ? start_position + run.setpoint : run.setpoint;
  const auto period = std::chrono::duration<double>(o.period_ms * 1e-3);
  const auto t0 = std::chrono::steady_clock::now();
  auto next = t0;
  int cycles = 0;
  int bad = 0;
  fb::Cia402Reading r{};
  fb::Cia402Status last = fb::Cia402Status::kOk;
  std::string stop_reason = "time";
  for (;;) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (g_stop) {
      stop_reason = "interrupted (deadman)";
      break;
    }
    if (run.for_s > 0.0 && t >= run.for_s) break;
    const fb::Cia402Status rs = drive.Read(r);
    if (rs != fb::Cia402Status::kOk && rs != fb::Cia402Status::kNoNewData) {
      if (++bad >= 3) {
        last = rs;
        stop_reason = fmt::format("the drive reported {} ({})", fb::ToString(rs), cia402::ToString(r.state));
        break;
      }
    } else {
      bad = 0;
    }
    const double command = mode == fb::Cia402Mode::kCyclicSynchronousPosition && !run.relative && run.setpoint == 0.0
                               ? start_position
                               : target;
    (void)(mode == fb::Cia402Mode::kCyclicSynchronousPosition   ? drive.WritePosition_rad(command)
           : mode == fb::Cia402Mode::kCyclicSynchronousVelocity ? drive.WriteVelocity_rad_per_s(command)
                                                                : drive.WriteTorque_Nm(command));
    if (csv != nullptr && r.fresh) {
      std::fprintf(csv, "%.6f,%s,%s,0x%04X,%.6f,%.6f,%.6f,%.6f\n", t, fb::ToString(rs), cia402::ToString(r.state),
                   r.statusword, r.position_rad, r.velocity_rad_per_s, r.torque_Nm, command);
    }
    ++cycles;
    // After a late wake-up the missed cycles are dropped, not run back to back: one SYNC per period on the wire.
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    for (const auto now = std::chrono::steady_clock::now(); next < now;) {
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    }
    std::this_thread::sleep_until(next);
  }
  // Stop: in velocity and torque mode a zero target first, in position mode the last target holds.
  if (mode != fb::Cia402Mode::kCyclicSynchronousPosition) {
    for (int k = 0; k < 5; ++k) {
      (void)drive.WriteHold();
      std::this_thread::sleep_for(period);
    }
  }
  const bool off = drive.Deactivate();
  consumer_off();
  if (csv != nullptr) std::fclose(csv);
  std::printf(
      "node %d: stopped after %d cycles (%s); last reading: position %.4f rad, velocity %.4f rad/s, torque "
      "%.4f N·m; %s\n",
      node, cycles, stop_reason.c_str(), r.position_rad, r.velocity_rad_per_s, r.torque_Nm,
      off ? "disabled" : drive.last_error().c_str());
  return last == fb::Cia402Status::kOk && off ? 0 : 1;
}

// ---- fault reset ----
int FaultReset(const Options& o, int node_arg) {
  const std::uint8_t node = NodeId(node_arg);
  auto port = OpenAll(o);
  canopen::SdoClient sdo(*port, node, SdoConfig(o, o.sdo_retries), fb::Timebase::Steady());
  const auto before = static_cast<std::uint16_t>(sdo.Upload(cia402::obj::kStatusword, 0, 2));
  const auto code = static_cast<std::uint16_t>(sdo.Upload(cia402::obj::kErrorCode, 0, 2));
  std::printf("node %d: %s (statusword 0x%04X), error 0x%04X %s\n", node,
              cia402::ToString(cia402::DecodeStatusword(before)), before, code, canopen::DescribeEmergencyCode(code));
  // Fault reset acts on the rising edge of controlword bit 7 (CiA 402): 0x0000, then 0x0080.
  sdo.Download(cia402::obj::kControlword, 0, 0x0000, 2);
  sdo.Download(cia402::obj::kControlword, 0, cia402::cw::kCmdFaultReset, 2);
  cia402::DriveState state = cia402::DriveState::kFault;
  std::uint16_t after = before;
  for (int k = 0; k < 50; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    after = static_cast<std::uint16_t>(sdo.Upload(cia402::obj::kStatusword, 0, 2));
    state = cia402::DecodeStatusword(after);
    if (state != cia402::DriveState::kFault && state != cia402::DriveState::kFaultReactionActive) break;
  }
  sdo.Download(cia402::obj::kControlword, 0, 0x0000, 2);
  std::printf("node %d: after fault reset: %s (statusword 0x%04X)\n", node, cia402::ToString(state), after);
  return state == cia402::DriveState::kFault || state == cia402::DriveState::kFaultReactionActive ? 1 : 0;
}

// ---- simulate ----
int Simulate(const Options& o, const std::vector<int>& nodes, double for_s, const std::string& modes_text,
             double fault_at_s, const std::string& fault_code_text, const fb::SimulatedLoopConfig& loops) {
  std::uint32_t fault_code = 0x2310;
  if (!canopen::ParseEdsValue(fault_code_text, 0, fault_code) || fault_code > 0xFFFF) {
    throw Error(fmt::format("--fault-code '{}' is not a 16-bit number", fault_code_text));
  }
  std::vector<std::unique_ptr<fb::CanPort>> ports;
  std::vector<std::unique_ptr<fb::SimulatedCia402Drive>> sims;
  std::uint32_t modes = 0x380;
  if (!modes_text.empty() && !canopen::ParseEdsValue(modes_text, 0, modes)) {
    throw Error(fmt::format("--supported-modes '{}' is not a number", modes_text));
  }
  for (const int n : nodes) {
    fb::SimulatedCia402DriveConfig c;
    c.node_id = NodeId(n);
    c.supported_modes = modes;
    c.rated_torque_mNm = static_cast<std::uint32_t>(std::lround(o.rated_torque_Nm * 1000.0));
    c.position_rad_per_count = o.position_rad_per_count;
    c.velocity_rad_per_s_per_unit = o.velocity_rad_per_s_per_unit;
    c.heartbeat_period_ms = 100;
    c.loops = loops;
    ports.push_back(fb::OpenCanPort(PortConfig(o), fb::SimulatedCia402Drive::ReceiveOptions(c)));
    sims.push_back(std::make_unique<fb::SimulatedCia402Drive>(c, *ports.back()));
  }
  spdlog::info("simulated CiA 402 drive{} on node{} {} ready", nodes.size() == 1 ? "" : "s",
               nodes.size() == 1 ? "" : "s", fmt::join(nodes, ", "));
  const std::uint64_t start = NowNs();
  bool faulted = false;
  while (!g_stop && (for_s <= 0.0 || NowNs() - start < static_cast<std::uint64_t>(for_s * 1e9))) {
    const std::uint64_t now = NowNs();
    if (!faulted && fault_at_s > 0.0 && now - start >= static_cast<std::uint64_t>(fault_at_s * 1e9)) {
      faulted = true;
      for (auto& s : sims) s->InjectFault(static_cast<std::uint16_t>(fault_code));
      spdlog::info("fault 0x{:04X} injected", fault_code);
    }
    for (auto& s : sims) s->Step(now);
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  return 0;
}

int Main(int argc, char** argv) {
  CLI::App app{"teleop-drive: commissioning of CiA 402 drives (scan, info, sdo, enable, jog, fault-reset, record)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-drive"));
  teleop::StandardHelp(app);
  app.require_subcommand(1);
  Options o;
  app.add_option("--can", o.can_interface, "SocketCAN interface (default can0)");
  app.add_option("--bus-port", o.bus_port, "the teleop-canbus emulated bus on UDP 127.0.0.1:PORT instead");
  app.add_option("--bus-host", o.bus_host, "teleop-canbus address")->capture_default_str();
  app.add_option("--sdo-timeout-ms", o.sdo_timeout_ms, "SDO response timeout")->capture_default_str();
  app.add_option("--sdo-retries", o.sdo_retries, "SDO retries after a timeout")->capture_default_str();
  app.add_option("--period-ms", o.period_ms, "cycle period of enable/jog/record")
      ->capture_default_str()
      ->check(CLI::Range(0.25, 100.0));
  app.add_option("--rated-torque", o.rated_torque_Nm, "0x6076 in N·m (torque scaling)")->capture_default_str();
  app.add_option("--position-per-count", o.position_rad_per_count, "rad per position unit")->capture_default_str();
  app.add_option("--velocity-per-unit", o.velocity_rad_per_s_per_unit, "rad/s per velocity unit")
      ->capture_default_str();
  app.add_option("--stale-ms", o.stale_ms,
                 "a TPDO older than this stops enable/jog/record (default: ten cycles, at least 10 ms)")
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--heartbeat-timeout-ms", o.heartbeat_timeout_ms,
                 "the drive's heartbeat (produced every 50 ms) missing this long stops enable/jog/record")
      ->capture_default_str()
      ->check(CLI::Range(60.0, 10000.0));
  app.add_option("--drive-consumer-timeout-ms", o.drive_consumer_timeout_ms,
                 "enable/jog/record: the drive faults itself when the tool's heartbeat (every 100 ms) is missing this "
                 "long, e.g. the tool was killed (0x1016:01; 0: off)")
      ->capture_default_str()
      ->check(CLI::Number);
  app.add_option("--eds", o.eds_file, "the drive's EDS/DCF: checked before the drive is touched (enable, jog, record)");

  int from = 1, to = 127;
  double scan_timeout_ms = 20.0;
  auto* scan = app.add_subcommand("scan", "find the nodes: NMT state (heartbeats), 0x1000 and 0x1018 of each");
  scan->add_option("--from", from, "first node-ID")->capture_default_str()->check(CLI::Range(1, 127));
  scan->add_option("--to", to, "last node-ID")->capture_default_str()->check(CLI::Range(1, 127));
  scan->add_option("--timeout-ms", scan_timeout_ms, "SDO timeout per node")->capture_default_str();

  int node = 0;
  auto* info = app.add_subcommand("info", "identity, device name, versions, supported modes, state, error history");
  info->add_option("NODE", node, "node-ID")->required();

  std::string sdo_op, index_text, sub_text, value_text, type = "u32";
  auto* sdo = app.add_subcommand("sdo", "sdo read|write NODE INDEX SUB [VALUE]");
  sdo->add_option("OP", sdo_op, "read or write")->required()->check(CLI::IsMember({"read", "write"}));
  sdo->add_option("NODE", node, "node-ID")->required();
  sdo->add_option("INDEX", index_text, "object index (0x6041)")->required();
  sdo->add_option("SUB", sub_text, "sub-index")->required();
  sdo->add_option("VALUE", value_text, "value to write");
  sdo->add_option("--type", type, "u8|u16|u32|i8|i16|i32|string")->capture_default_str();

  std::string mode_text = "torque";
  double limit = 0.0;
  double for_s = 0.0;
  auto* enable = app.add_subcommand("enable", "to Operation Enabled, hold (target 0 / the position) until --for or ^C");
  enable->add_option("NODE", node, "node-ID")->required();
  enable->add_option("--mode", mode_text, "torque|velocity|position")->capture_default_str();
  enable->add_option("--limit", limit, "torque: N·m (0x6072); velocity/position: rad/s")->required();
  enable->add_option("--for", for_s, "seconds (0: until interrupted)");

  std::optional<double> jog_torque, jog_velocity, jog_position;
  auto* jog = app.add_subcommand("jog", "move for --for S within --limit; stops when interrupted (deadman)");
  jog->add_option("NODE", node, "node-ID")->required();
  auto* jt = jog->add_option("--torque", jog_torque, "N·m");
  auto* jv = jog->add_option("--velocity", jog_velocity, "rad/s");
  auto* jp = jog->add_option("--position", jog_position, "rad, relative to where the joint is");
  jt->excludes(jv)->excludes(jp);
  jv->excludes(jp);
  jog->add_option("--limit", limit, "hard limit: |torque| N·m, or the speed in rad/s")->required();
  jog->add_option("--for", for_s, "seconds")->required()->check(CLI::PositiveNumber);

  auto* reset = app.add_subcommand("fault-reset", "fault reset (rising edge of controlword bit 7), state after");
  reset->add_option("NODE", node, "node-ID")->required();

  std::string csv;
  auto* record = app.add_subcommand("record", "enable holding (torque 0: the joint moves freely) and log every cycle");
  record->add_option("NODE", node, "node-ID")->required();
  record->add_option("--csv", csv, "output file")->required();
  record->add_option("--for", for_s, "seconds")->required()->check(CLI::PositiveNumber);
  record->add_option("--mode", mode_text, "torque|velocity|position")->capture_default_str();
  record->add_option("--limit", limit, "as for enable")->default_val(0.1);

  std::vector<int> sim_nodes;
  std::string sim_modes;
  auto* simulate = app.add_subcommand("simulate", "simulated CiA 402 drives on the bus (the walkthrough, tests)");
  simulate->add_option("--node", sim_nodes, "node-ID (repeat for several drives)")->required();
  simulate->add_option("--for", for_s, "seconds (0: until interrupted)");
  simulate->add_option("--supported-modes", sim_modes, "0x6502 of the simulated drives (default 0x380)");
  double fault_at_s = 0.0;
  std::string fault_code = "0x2310";
  fb::SimulatedLoopConfig loops;
  simulate->add_option("--position-kp", loops.position_kp_per_s, "the drives' position loop gain (1/s)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  simulate->add_option("--velocity-kp", loops.velocity_kp_Nms_per_rad, "velocity loop gain (N·m·s/rad)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  simulate->add_option("--velocity-ki", loops.velocity_ki_Nm_per_rad, "velocity loop integral gain (N·m/rad)")
      ->capture_default_str();
  simulate->add_option("--fault-at-s", fault_at_s, "inject a drive fault this long after the start (0: never)");
  simulate->add_option("--fault-code", fault_code, "the fault's error code (EMCY, 0x603F, 0x1003)")
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  if (o.can_interface.empty() && o.bus_port == 0) o.can_interface = "can0";
  try {
    fb::Cia402Mode mode{};
    if (!fb::ParseCia402Mode(mode_text, mode)) {
      throw Error(fmt::format("--mode {}: torque, velocity or position (csp/csv/cst, 8/9/10)", mode_text));
    }
    if (*scan) return Scan(o, from, to, scan_timeout_ms);
    if (*info) return Info(o, node);
    if (*sdo) return Sdo(o, sdo_op, node, index_text, sub_text, value_text, type);
    if (*enable) return Cycle(o, node, mode, limit, Run{for_s, 0.0, false, {}});
    if (*record) return Cycle(o, node, mode, limit, Run{for_s, 0.0, false, csv});
    if (*reset) return FaultReset(o, node);
    if (*simulate) return Simulate(o, sim_nodes, for_s, sim_modes, fault_at_s, fault_code, loops);
    if (*jog) {
      if (!jog_torque && !jog_velocity && !jog_position) throw Error("jog: give --torque, --velocity or --position");
      const double value = jog_torque ? *jog_torque : jog_velocity ? *jog_velocity : *jog_position;
      const fb::Cia402Mode jog_mode = jog_torque     ? fb::Cia402Mode::kCyclicSynchronousTorque
                                      : jog_velocity ? fb::Cia402Mode::kCyclicSynchronousVelocity
                                                     : fb::Cia402Mode::kCyclicSynchronousPosition;
      if (!std::isfinite(value)) throw Error("jog: the setpoint is not a number");
      if (jog_mode != fb::Cia402Mode::kCyclicSynchronousPosition && std::abs(value) > limit) {
        throw Error(fmt::format("jog: {} {} exceeds --limit {} (the hard limit); nothing was sent",
                                jog_torque ? "--torque" : "--velocity", value, limit));
      }
      return Cycle(o, node, jog_mode, limit,
                   Run{for_s, value, jog_mode == fb::Cia402Mode::kCyclicSynchronousPosition, {}});
    }
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "teleop-drive: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "teleop-drive: unexpected error: %s\n", e.what());
    return 3;
  }
}
