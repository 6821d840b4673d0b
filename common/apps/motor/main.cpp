// teleop-motor: commissioning of MIT-mode joint motors (Damiao DM-J class) on SocketCAN or the emulated bus
// (docs/mit-motors.md, "Bring-up with teleop-motor").
//
//   teleop-motor [--can can0 | --bus-port 47300] [--model DM-J4310] scan [--from 1 --to 32]
//   teleop-motor ... info ID                       ids, timeout, mode, firmware, ranges against the model
//   teleop-motor ... enable ID | disable ID | clear ID
//   teleop-motor ... zero ID --confirm             the current position becomes 0 (the motor is disabled first)
//   teleop-motor ... jog ID (--torque T | --velocity V | --position P) --limit L --for S
//   teleop-motor ... param read ID REG | param write ID REG VALUE
//   teleop-motor ... record ID --csv FILE --for S  enabled at zero torque (the joint moves freely), every cycle logged
//   teleop-motor ... simulate --id N [--id M ...]  simulated motors on the bus (the walkthrough, tests)
//   teleop-motor bus-load --motors 7 --rate-hz 1000 [--fd]  the bus time an MIT rig needs (no bus opened)
//
// jog and record run one exchange per --period-ms. Before a jog the motor's own CAN timeout (register 9) is set to
// --motor-timeout-ms, so a tool that dies (SIGKILL, a cable) leaves the motor disabled; SIGINT/SIGTERM (the deadman),
// the end of --for, the hard limit, a fault code or a motor that stops answering each stop it: zero command, disable.
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
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "teleop/cli_help.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/mit_motor_bus.hpp"
#include "teleop/fieldbus/mit_motor_models.hpp"
#include "teleop/fieldbus/simulated_mit_motor.hpp"
#include "teleop/version.hpp"

namespace {

using teleop::Error;
namespace fb = teleop::fieldbus;
namespace mit = teleop::proto::can::mit;

std::atomic<bool> g_stop{false};
void OnSignal(int /*signal*/) { g_stop = true; }

std::int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Options {
  std::string can_interface;
  std::string bus_host = "127.0.0.1";
  int bus_port = 0;
  bool fd = false;
  std::string model = "DM-J4310";
  std::string models_file;
  int master_offset = 0x10;
  double answer_timeout_ms = 20.0;
  double period_ms = 1.0;
  double motor_timeout_ms = 100.0;
  int missing_limit = 10;
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

fb::MitMotorModel Model(const Options& o) {
  const std::string path = o.models_file.empty() ? fb::DefaultMitMotorModelsPath() : o.models_file;
  const auto models = fb::ReadMitMotorModels(path);
  return fb::FindMitMotorModel(models, o.model, path);
}

std::uint32_t EscId(int id) {
  if (id < 1 || id > 0x7FE) throw Error(fmt::format("motor id {} is not 1..0x7FE", id));
  return static_cast<std::uint32_t>(id);
}

/// One motor on its own bus object (its master id = id + --master-offset unless the motor says otherwise).
struct Session {
  std::unique_ptr<fb::CanPort> port;
  std::unique_ptr<fb::MitMotorBus> bus;
  fb::MitMotorModel model;
};

Session Open(const Options& o, int id) {
  Session s;
  s.model = Model(o);
  fb::MitMotorConfig m;
  m.name = fmt::format("motor 0x{:02X}", id);
  m.esc_id = EscId(id);
  m.master_id = m.esc_id + static_cast<std::uint32_t>(o.master_offset);
  m.ranges = s.model.ranges;
  const std::vector<fb::MitMotorConfig> motors{m};
  s.port = fb::OpenCanPort(PortConfig(o), fb::MitMotorBus::ReceiveOptions(motors));
  s.bus = std::make_unique<fb::MitMotorBus>(*s.port, motors, o.fd);
  return s;
}

double Seconds(double ms) { return ms * 1e-3; }

/// The motor's answer to a special frame, or an error naming what did not happen.
void Special(const Options& o, Session& s, mit::Special what, const char* name) {
  if (!s.bus->SendSpecialAndWait(what, Seconds(o.answer_timeout_ms)).empty()) {
    throw Error(
        fmt::format("{}: no answer to {} within {} ms (is it powered and on this bus? is its master id "
                    "0x{:X}? teleop-motor scan lists what answers)",
                    s.bus->config(0).name, name, o.answer_timeout_ms, s.bus->config(0).master_id));
  }
}

void PrintState(const Session& s) {
  const mit::Feedback& f = s.bus->state(0).feedback;
  std::printf(
      "%s: %s (code 0x%X), position %.4f rad, velocity %.3f rad/s, torque %.3f N·m, MOS %.0f °C, rotor "
      "%.0f °C\n",
      s.bus->config(0).name.c_str(), std::string(mit::StatusName(f.status)).c_str(), f.status, f.position_rad,
      f.velocity_rad_per_s, f.torque_Nm, f.mos_temperature_C, f.rotor_temperature_C);
}

// ---- scan ----
int Scan(const Options& o, int from, int to) {
  auto port = fb::OpenCanPort(PortConfig(o), teleop::transport::CanReceiveOptions::Everything());
  int found = 0;
  for (int id = from; id <= to && !g_stop; ++id) {
    teleop::proto::can::CanFrame req;
    mit::EncodeParameter(mit::Parameter{static_cast<std::uint16_t>(id), mit::ParameterOp::kRead,
                                        static_cast<std::uint8_t>(mit::Register::kMasterId), 0},
                         req);
    if (port->Write(req) != teleop::transport::CanWriteStatus::kOk) throw Error("scan: the bus refused a frame");
    const std::int64_t deadline = NowNs() + static_cast<std::int64_t>(o.answer_timeout_ms * 1e6);
    while (NowNs() < deadline) {
      teleop::proto::can::CanFrame f;
      if (!port->Read(f)) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
        continue;
      }
      const auto p = mit::DecodeParameter(f);
      if (p && f.id != mit::kParameterId && p->esc_id == id && p->op == mit::ParameterOp::kRead &&
          p->reg == static_cast<std::uint8_t>(mit::Register::kMasterId)) {
        std::printf("motor 0x%02X: answers on master id 0x%02X\n", id, p->value);
        ++found;
        break;
      }
    }
  }
  std::printf("%d motor%s answered (ids %d..%d)\n", found, found == 1 ? "" : "s", from, to);
  return found > 0 ? 0 : 1;
}

// ---- info ----
int Info(const Options& o, int id) {
  Session s = Open(o, id);
  auto read = [&](mit::Register r, const char* what) {
    const auto v = s.bus->ReadRegister(0, static_cast<std::uint8_t>(r), Seconds(o.answer_timeout_ms));
    if (!v) {
      throw Error(
          fmt::format("{}: no answer to the read of {} within {} ms (is the master id 0x{:X}? teleop-motor "
                      "scan shows it)",
                      s.bus->config(0).name, what, o.answer_timeout_ms, s.bus->config(0).master_id));
    }
    return *v;
  };
  const std::uint32_t timeout = read(mit::Register::kTimeout, "TIMEOUT");
  std::printf("%s\n  master id 0x%02X\n  control mode %u%s\n  firmware 0x%X\n  CAN timeout %u (%.1f ms%s)\n",
              s.bus->config(0).name.c_str(), read(mit::Register::kMasterId, "MST_ID"),
              read(mit::Register::kControlMode, "CTRL_MODE"),
              read(mit::Register::kControlMode, "CTRL_MODE") == mit::kControlModeMit ? " (MIT)" : " (not MIT)",
              read(mit::Register::kFirmware, "sw_ver"), timeout, timeout * mit::kTimeoutCount_s * 1e3,
              timeout == 0 ? ": off, a dead host leaves it running" : "");
  auto as_float = [](std::uint32_t v) { return mit::Parameter{0, mit::ParameterOp::kRead, 0, v}.FloatValue(); };
  std::printf("  P_MAX %g rad, V_MAX %g rad/s, T_MAX %g N·m on the motor; model %s: %g, %g, %g\n",
              static_cast<double>(as_float(read(mit::Register::kPositionMax, "PMAX"))),
              static_cast<double>(as_float(read(mit::Register::kVelocityMax, "VMAX"))),
              static_cast<double>(as_float(read(mit::Register::kTorqueMax, "TMAX"))), o.model.c_str(),
              s.model.ranges.position_max_rad, s.model.ranges.velocity_max_rad_per_s, s.model.ranges.torque_max_Nm);
  s.bus->VerifyRanges(0, Seconds(o.answer_timeout_ms));  // throws naming the register that differs
  std::printf("  ranges match the model\n");
  return 0;
}

// ---- param ----
std::optional<std::uint8_t> RegisterByName(const std::string& text) {
  static const std::map<std::string, mit::Register> kNames{
      {"master_id", mit::Register::kMasterId}, {"esc_id", mit::Register::kEscId},
      {"timeout", mit::Register::kTimeout},    {"control_mode", mit::Register::kControlMode},
      {"firmware", mit::Register::kFirmware},  {"p_max", mit::Register::kPositionMax},
      {"v_max", mit::Register::kVelocityMax},  {"t_max", mit::Register::kTorqueMax}};
  if (const auto it = kNames.find(text); it != kNames.end()) return static_cast<std::uint8_t>(it->second);
  char* end = nullptr;
  const long n = std::strtol(text.c_str(), &end, 10);
  if (end != nullptr && *end == '\0' && !text.empty() && n >= 0 && n <= 255) return static_cast<std::uint8_t>(n);
  return std::nullopt;
}

int Param(const Options& o, const std::string& op, int id, const std::string& reg_text, const std::string& value) {
  const auto reg = RegisterByName(reg_text);
  if (!reg) {
    throw Error(
        fmt::format("register '{}': a number 0..255 or one of master_id, esc_id, timeout, control_mode, "
                    "firmware, p_max, v_max, t_max",
                    reg_text));
  }
  Session s = Open(o, id);
  const bool is_float = mit::IsFloatRegister(*reg);
  if (op == "read") {
    const auto v = s.bus->ReadRegister(0, *reg, Seconds(o.answer_timeout_ms));
    if (!v) throw Error(fmt::format("{}: no answer to the read of register {}", s.bus->config(0).name, *reg));
    if (is_float) {
      std::printf("register %u = %g\n", *reg,
                  static_cast<double>(mit::Parameter{0, mit::ParameterOp::kRead, 0, *v}.FloatValue()));
    } else {
      std::printf("register %u = %u (0x%X)\n", *reg, *v, *v);
    }
    return 0;
  }
  if (value.empty()) throw Error("param write: give the VALUE");
  std::uint32_t raw = 0;
  try {
    std::size_t used = 0;
    if (is_float) {
      const double d = std::stod(value, &used);
      if (!std::isfinite(d)) throw std::invalid_argument("not finite");
      raw = mit::Parameter::FromFloat(static_cast<float>(d));
    } else {
      const unsigned long u = std::stoul(value, &used, 10);
      if (u > 0xFFFFFFFFUL) throw std::out_of_range("32 bits");
      raw = static_cast<std::uint32_t>(u);
    }
    if (used != value.size()) throw std::invalid_argument("trailing characters");
  } catch (const std::exception&) {
    throw Error(fmt::format("param write: '{}' is not a {} for register {}", value,
                            is_float ? "finite number" : "decimal whole number 0..4294967295", *reg));
  }
  Special(o, s, mit::Special::kDisable, "disable");  // the motor takes writes only while disabled
  if (!s.bus->WriteRegister(0, *reg, raw, Seconds(o.answer_timeout_ms))) {
    throw Error(fmt::format("{}: register {} was not written (no answer, or the motor refused the value)",
                            s.bus->config(0).name, *reg));
  }
  std::printf("register %u written (the motor keeps it until power-off; the vendor's save-to-flash is not sent)\n",
              *reg);
  return 0;
}

// ---- the cycle: jog and record ----
struct Run {
  std::optional<double> torque, velocity, position;
  double limit = 0;
  double for_s = 0;
  double kp = 10.0;
  double kd = 0.5;
  std::string csv;
};

/// Why a cycle stopped, or empty while it runs.
std::string Check(const Options& o, const fb::MitMotorState& st, const Run& r) {
  if (g_stop) return "interrupted (deadman)";
  if (st.missing_in_a_row >= o.missing_limit) {
    return fmt::format("the motor stopped answering ({} exchanges in a row without feedback)", st.missing_in_a_row);
  }
  if (st.answered && mit::IsFault(st.feedback.status)) {
    return fmt::format("the motor reports {} (code 0x{:X})", mit::StatusName(st.feedback.status), st.feedback.status);
  }
  if (st.answered && st.feedback.status == 0) return "the motor disabled itself";
  const double speed_limit = r.torque ? std::numeric_limits<double>::infinity() : r.limit;
  if (st.answered && std::abs(st.feedback.velocity_rad_per_s) > 1.2 * speed_limit) {
    return fmt::format("hard limit: {:.3f} rad/s beyond --limit {} rad/s", st.feedback.velocity_rad_per_s, r.limit);
  }
  return {};
}

int Cycle(const Options& o, int id, const Run& r) {
  Session s = Open(o, id);
  s.bus->VerifyRanges(0, Seconds(o.answer_timeout_ms));
  Special(o, s, mit::Special::kDisable, "disable");
  const auto counts = static_cast<std::uint32_t>(std::lround(o.motor_timeout_ms * 1e-3 / mit::kTimeoutCount_s));
  if (!s.bus->WriteRegister(0, static_cast<std::uint8_t>(mit::Register::kTimeout), counts,
                            Seconds(o.answer_timeout_ms))) {
    throw Error(
        fmt::format("{}: could not set its CAN timeout to {} ms (register 9): not moving a motor that a dead "
                    "tool would leave running",
                    s.bus->config(0).name, o.motor_timeout_ms));
  }
  std::ofstream csv;
  if (!r.csv.empty()) {
    csv.open(r.csv);
    if (!csv) throw Error(fmt::format("cannot write {}", r.csv));
    csv << "t_s,position_rad,velocity_rad_per_s,torque_Nm,status,mos_C,rotor_C\n";
  }
  Special(o, s, mit::Special::kEnable, "enable");
  const double start_rad = s.bus->state(0).feedback.position_rad;
  const double period_s = Seconds(o.period_ms);
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(period_s * 1e9));
  const std::int64_t t0 = NowNs();
  auto next = std::chrono::steady_clock::now();
  std::string why;
  double target_rad = start_rad;
  while (true) {
    const double t = static_cast<double>(NowNs() - t0) * 1e-9;
    if (t >= r.for_s) {
      why = fmt::format("--for {} s done", r.for_s);
      break;
    }
    mit::Command c;
    if (r.torque) {
      c.torque_Nm = std::clamp(*r.torque, -s.model.peak_torque_Nm, s.model.peak_torque_Nm);
    } else if (r.velocity) {
      c.velocity_rad_per_s = *r.velocity;
      c.kd_Nm_s_per_rad = r.kd;
    } else if (r.position) {  // the target moves towards start + P at most --limit rad/s
      const double goal = start_rad + *r.position;
      target_rad += std::clamp(goal - target_rad, -r.limit * period_s, r.limit * period_s);
      c.position_rad = target_rad;
      c.kp_Nm_per_rad = r.kp;
      c.kd_Nm_s_per_rad = r.kd;
    }
    s.bus->SetCommand(0, c);
    (void)s.bus->Exchange();
    const fb::MitMotorState& st = s.bus->state(0);
    if (csv && st.answered) {
      const mit::Feedback& f = st.feedback;
      csv << fmt::format("{:.6f},{:.6f},{:.5f},{:.5f},{},{:.0f},{:.0f}\n", t, f.position_rad, f.velocity_rad_per_s,
                         f.torque_Nm, f.status, f.mos_temperature_C, f.rotor_temperature_C);
    }
    why = Check(o, st, r);
    if (!why.empty()) break;
    next += period;
    const auto now = std::chrono::steady_clock::now();
    if (next < now) next = now;  // a late wake-up: no burst of exchanges to catch up
    std::this_thread::sleep_until(next);
  }
  s.bus->SetCommand(0, mit::Command{});
  (void)s.bus->Exchange();
  const bool answered_disable = s.bus->SendSpecialAndWait(mit::Special::kDisable, Seconds(o.answer_timeout_ms)).empty();
  PrintState(s);
  const fb::MitMotorState& st = s.bus->state(0);
  std::printf("stopped: %s; %llu exchanges, %llu without feedback, %llu clamped%s\n", why.c_str(),
              static_cast<unsigned long long>(s.bus->counters().exchanges), static_cast<unsigned long long>(st.missing),
              static_cast<unsigned long long>(st.clamped),
              answered_disable ? "" : "; the disable was not answered (the motor's own timeout disables it)");
  const bool clean = why.rfind("--for", 0) == 0 || why.rfind("interrupted", 0) == 0;
  return clean ? 0 : 1;
}

// ---- bus-load ----
int BusLoad(const Options& o, int motors, double rate_hz, double nominal_bit_per_s, double data_bit_per_s,
            double max_load) {
  const mit::MitBusLoad b =
      mit::ComputeMitBusLoad(motors, rate_hz, o.fd, o.fd, nominal_bit_per_s, data_bit_per_s, max_load);
  std::printf("%s, %g Mbit/s%s: one exchange (command + feedback, 8 bytes each, worst-case stuffing) %.1f µs\n",
              o.fd ? "CAN FD" : "classic CAN", nominal_bit_per_s * 1e-6,
              o.fd ? fmt::format(" arbitration, {:g} Mbit/s data", data_bit_per_s * 1e-6).c_str() : "",
              b.exchange_time_s * 1e6);
  std::printf("%d motor%s at %g Hz: load %.2f of the bus (%s); within %.0f %%: %d motor%s per bus\n", motors,
              motors == 1 ? "" : "s", rate_hz, b.load, b.load <= max_load ? "fits" : "does not fit", max_load * 100,
              b.max_motors, b.max_motors == 1 ? "" : "s");
  return b.load <= max_load ? 0 : 1;
}

// ---- simulate ----
int Simulate(const Options& o, const std::vector<int>& ids, double for_s, double fault_at_s, const std::string& fault) {
  static const std::map<std::string, mit::MotorStatus> kFaults{
      {"over-voltage", mit::MotorStatus::kOverVoltage},
      {"under-voltage", mit::MotorStatus::kUnderVoltage},
      {"over-current", mit::MotorStatus::kOverCurrent},
      {"mos-over-temperature", mit::MotorStatus::kMosOverTemperature},
      {"coil-over-temperature", mit::MotorStatus::kCoilOverTemperature},
      {"overload", mit::MotorStatus::kOverload}};
  const auto f = kFaults.find(fault);
  if (f == kFaults.end()) {
    throw Error(
        fmt::format("--fault '{}': over-voltage, under-voltage, over-current, mos-over-temperature, "
                    "coil-over-temperature or overload",
                    fault));
  }
  const fb::MitMotorModel model = Model(o);
  std::vector<std::unique_ptr<fb::CanPort>> ports;
  std::vector<std::unique_ptr<fb::SimulatedMitMotor>> motors;
  for (const int id : ids) {
    fb::SimulatedMitMotorConfig c;
    c.esc_id = EscId(id);
    c.master_id = c.esc_id + static_cast<std::uint32_t>(o.master_offset);
    c.ranges = model.ranges;
    c.peak_torque_Nm = model.peak_torque_Nm;
    ports.push_back(fb::OpenCanPort(PortConfig(o), fb::SimulatedMitMotor::ReceiveOptions(c)));
    motors.push_back(std::make_unique<fb::SimulatedMitMotor>(c, *ports.back()));
  }
  spdlog::info("simulated {} motor{} on id{} {} ready", o.model, ids.size() == 1 ? "" : "s", ids.size() == 1 ? "" : "s",
               fmt::join(ids, ", "));
  const std::int64_t start = NowNs();
  bool faulted = false;
  while (!g_stop && (for_s <= 0.0 || NowNs() - start < static_cast<std::int64_t>(for_s * 1e9))) {
    const std::int64_t now = NowNs();
    if (!faulted && fault_at_s > 0.0 && now - start >= static_cast<std::int64_t>(fault_at_s * 1e9)) {
      faulted = true;
      for (auto& m : motors) m->InjectFault(f->second);
      spdlog::info("fault {} injected", mit::StatusName(static_cast<std::uint8_t>(f->second)));
    }
    for (auto& m : motors) m->Step(now);
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  return 0;
}

int Main(int argc, char** argv) {
  CLI::App app{
      "teleop-motor: commissioning of MIT-mode joint motors (scan, info, enable, disable, clear, zero, jog, "
      "param, record, simulate, bus-load)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-motor"));
  teleop::StandardHelp(app);
  app.require_subcommand(1);
  Options o;
  app.add_option("--can", o.can_interface, "SocketCAN interface (default can0)");
  app.add_option("--bus-port", o.bus_port,
                 "the teleop-canbus emulated bus on UDP 127.0.0.1:PORT instead (0: SocketCAN)");
  app.add_option("--bus-host", o.bus_host, "teleop-canbus address")->capture_default_str();
  app.add_flag("--fd", o.fd, "send CAN FD frames (bit-rate switch): motors configured for CAN FD");
  app.add_option("--model", o.model, "motor model in the models file")->capture_default_str();
  app.add_option("--models", o.models_file, "the models file (default: the shipped deploy/motors/mit-models.yaml)");
  app.add_option("--master-offset", o.master_offset, "master id = motor id + this (the vendors' convention)")
      ->capture_default_str()
      ->check(CLI::Range(0, 0x7FE));
  app.add_option("--answer-timeout-ms", o.answer_timeout_ms, "how long to wait for each answer")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--period-ms", o.period_ms, "cycle period of jog and record")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 100.0));
  app.add_option("--motor-timeout-ms", o.motor_timeout_ms,
                 "the motor's own CAN timeout set before jog/record: a dead tool leaves it disabled this long after "
                 "its last frame")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--missing-limit", o.missing_limit,
                 "jog and record stop after this many exchanges in a row without the motor's feedback")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));

  int id = 0;
  int from = 1;
  int to = 32;
  bool confirm = false;
  Run run;
  std::string op;
  std::string reg;
  std::string value;
  std::vector<int> sim_ids;
  double sim_for_s = 0;
  double fault_at_s = 0;
  std::string fault = "coil-over-temperature";

  auto* scan = app.add_subcommand("scan", "which motor ids answer (a read of register 7, master id)");
  scan->add_option("--from", from, "first id")->capture_default_str()->check(CLI::Range(1, 0x7FE));
  scan->add_option("--to", to, "last id")->capture_default_str()->check(CLI::Range(1, 0x7FE));
  auto* info = app.add_subcommand("info", "master id, control mode, firmware, CAN timeout, ranges against the model");
  info->add_option("ID", id, "motor id")->required();
  auto* enable = app.add_subcommand("enable", "enable (zero torque until commanded)");
  enable->add_option("ID", id, "motor id")->required();
  auto* disable = app.add_subcommand("disable", "disable");
  disable->add_option("ID", id, "motor id")->required();
  auto* clear = app.add_subcommand("clear", "clear a latched error code (the motor stays disabled)");
  clear->add_option("ID", id, "motor id")->required();
  auto* zero = app.add_subcommand("zero", "make the current position 0 (disables the motor first)");
  zero->add_option("ID", id, "motor id")->required();
  zero->add_flag("--confirm", confirm, "required: the joint's zero moves, and every calibration with it");
  auto* jog = app.add_subcommand("jog", "move for --for S within --limit; stops when interrupted (deadman)");
  jog->add_option("ID", id, "motor id")->required();
  auto* jt = jog->add_option("--torque", run.torque, "N·m (Kp = Kd = 0)");
  auto* jv = jog->add_option("--velocity", run.velocity, "rad/s (the motor's Kd, --kd)");
  auto* jp = jog->add_option("--position", run.position, "rad from where the joint is (the motor's PD, --kp --kd)");
  jt->excludes(jv)->excludes(jp);
  jv->excludes(jp);
  jog->add_option("--limit", run.limit, "hard limit: |torque| N·m, or the speed in rad/s")
      ->required()
      ->check(CLI::PositiveNumber);
  jog->add_option("--for", run.for_s, "seconds")->required()->check(CLI::PositiveNumber);
  jog->add_option("--kp", run.kp, "position gain, N·m/rad (0..500)")->capture_default_str()->check(CLI::Range(0, 500));
  jog->add_option("--kd", run.kd, "damping gain, N·m·s/rad (0..5)")->capture_default_str()->check(CLI::Range(0, 5));
  auto* param = app.add_subcommand("param", "param read ID REG | param write ID REG VALUE");
  param->add_option("OP", op, "read or write")->required()->check(CLI::IsMember({"read", "write"}));
  param->add_option("ID", id, "motor id")->required();
  param->add_option("REG", reg, "register number or name (p_max, v_max, t_max, timeout, master_id, ...)")->required();
  param->add_option("VALUE", value, "value to write (decimal; a number for p_max, v_max, t_max)");
  auto* record = app.add_subcommand("record", "enabled at zero torque (the joint moves freely), every cycle to CSV");
  record->add_option("ID", id, "motor id")->required();
  record->add_option("--csv", run.csv, "output file")->required();
  record->add_option("--for", run.for_s, "seconds")->required()->check(CLI::PositiveNumber);
  auto* simulate = app.add_subcommand("simulate", "simulated motors of --model on the bus (the walkthrough, tests)");
  simulate->add_option("--id", sim_ids, "motor id (repeat for several motors)")->required();
  simulate->add_option("--for", sim_for_s, "seconds (0: until interrupted)")->capture_default_str();
  simulate->add_option("--fault-at-s", fault_at_s, "inject --fault this long after the start (0: never)")
      ->capture_default_str();
  simulate->add_option("--fault", fault, "the fault injected")->capture_default_str();

  int load_motors = 7;
  double load_rate_hz = 1000.0;
  double nominal_bit_per_s = 1e6;
  double data_bit_per_s = 5e6;
  double max_load = 0.8;
  auto* bus_load = app.add_subcommand("bus-load", "the bus time a rig of MIT motors needs per cycle (no bus opened)");
  bus_load->add_option("--motors", load_motors, "motors on the bus")->capture_default_str()->check(CLI::Range(1, 64));
  bus_load->add_option("--rate-hz", load_rate_hz, "exchanges per second")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100000.0));
  bus_load->add_option("--bitrate", nominal_bit_per_s, "nominal (arbitration) bit rate, bit/s")
      ->capture_default_str()
      ->check(CLI::Range(1e4, 1e6));
  bus_load->add_option("--data-bitrate", data_bit_per_s, "CAN FD data-phase bit rate, bit/s (with --fd)")
      ->capture_default_str()
      ->check(CLI::Range(1e5, 8e6));
  bus_load->add_option("--max-load", max_load, "the share of the bus a rig may use")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));

  CLI11_PARSE(app, argc, argv);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  try {
    if (*bus_load) return BusLoad(o, load_motors, load_rate_hz, nominal_bit_per_s, data_bit_per_s, max_load);
    if (*scan) return Scan(o, from, to);
    if (*info) return Info(o, id);
    if (*simulate) return Simulate(o, sim_ids, sim_for_s, fault_at_s, fault);
    if (*param) return Param(o, op, id, reg, value);
    if (*record) {
      run.torque = 0.0;
      run.limit = 1e9;
      return Cycle(o, id, run);
    }
    if (*jog) {
      if (!run.torque && !run.velocity && !run.position) throw Error("jog: give --torque, --velocity or --position");
      const double v = run.torque ? *run.torque : run.velocity ? *run.velocity : *run.position;
      if (!std::isfinite(v)) throw Error("jog: the setpoint is not a number");
      if (!run.position && std::abs(v) > run.limit) {
        throw Error(fmt::format("jog: {} {} exceeds --limit {} (the hard limit); nothing was sent",
                                run.torque ? "--torque" : "--velocity", v, run.limit));
      }
      return Cycle(o, id, run);
    }
    Session s = Open(o, id);
    if (*zero) {
      if (!confirm) throw Error("zero: the joint's zero moves, and every calibration with it: add --confirm");
      Special(o, s, mit::Special::kDisable, "disable");
      Special(o, s, mit::Special::kSetZero, "set zero");
    } else if (*enable) {
      Special(o, s, mit::Special::kEnable, "enable");
    } else if (*disable) {
      Special(o, s, mit::Special::kDisable, "disable");
    } else if (*clear) {
      Special(o, s, mit::Special::kClearError, "clear error");
    }
    PrintState(s);
    const std::uint8_t status = s.bus->state(0).feedback.status;
    if (*enable && status != static_cast<std::uint8_t>(mit::MotorStatus::kEnabled)) {
      throw Error(fmt::format("{}: not enabled: it reports {} (teleop-motor clear {} first)", s.bus->config(0).name,
                              mit::StatusName(status), id));
    }
    return mit::IsFault(status) ? 1 : 0;
  } catch (const Error& e) {
    std::fflush(stdout);  // what was found before the error, then the error
    std::fprintf(stderr, "teleop-motor: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "teleop-motor: unexpected error: %s\n", e.what());
    return 3;
  }
}
