#include "teleop/runtime/telemetry.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <iterator>
#include <system_error>

#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::runtime {

namespace {

/// How long the writer thread sleeps when the ring is empty. At 4 kHz a 16384-record ring holds 4 s, so this is
/// far from the limit; it only bounds the writer's wake-ups.
constexpr auto kDrainInterval = std::chrono::milliseconds(2);

const double* VectorField(const TelemetryRecord& r, int column) noexcept {
  switch (column) {
    case 0:
      return r.position_m;
    case 1:
      return r.velocity_m_per_s;
    case 2:
      return r.force_sensor_N;
    case 3:
      return r.command_N;
    case 4:
      return r.rendered_force_N;
    case 5:
      return r.fixture_force_N;
    case 6:
      return r.peer_position_m;
    case 7:
      return r.peer_velocity_m_per_s;
    default:
      return r.peer_force_N;
  }
}

constexpr const char* kVectorNames[] = {"position_m",      "velocity_m_per_s",      "force_sensor_N",
                                        "command_N",       "rendered_force_N",      "fixture_force_N",
                                        "peer_position_m", "peer_velocity_m_per_s", "peer_force_N"};
constexpr int kVectorCount = static_cast<int>(std::size(kVectorNames));

int ClampDof(int dof) noexcept { return std::clamp(dof, 1, kMaxDof); }
int ClampJoints(int joints) noexcept { return std::clamp(joints, 0, kMaxDof); }

}  // namespace

std::string TelemetryCsvHeader(int dof, int joints) {
  dof = ClampDof(dof);
  joints = ClampJoints(joints);
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out), "cycle,time_s,dof");
  for (int v = 0; v < kVectorCount; ++v) {
    for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",{}_{}", kVectorNames[v], i);
  }
  fmt::format_to(std::back_inserter(out),
                 ",fixture_penetration_m,law_status,flags,rtt_s,compute_s,engagement,data_age_s");
  for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",passivity_observed_J_{}", i);
  for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",passivity_damping_Ns_per_m_{}", i);
  fmt::format_to(std::back_inserter(out), ",device_warnings,clutch,fixture_stiffness_N_per_m,fixture_limit_N_per_m");
  // Last, so that the columns before them are the same for every device.
  for (int i = 0; i < joints; ++i) fmt::format_to(std::back_inserter(out), ",joint_position_rad_{}", i);
  for (int i = 0; i < joints; ++i) fmt::format_to(std::back_inserter(out), ",joint_torque_Nm_{}", i);
  return fmt::to_string(out);
}

std::string TelemetryCsvRow(const TelemetryRecord& r, int dof, int joints) {
  dof = ClampDof(dof);
  joints = ClampJoints(joints);
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out), "{},{},{}", r.cycle, r.time_s, r.dof);
  for (int v = 0; v < kVectorCount; ++v) {
    const double* values = VectorField(r, v);
    for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",{}", values[i]);
  }
  fmt::format_to(std::back_inserter(out), ",{},{},{},{},{},{},{}", r.fixture_penetration_m, r.law_status, r.flags,
                 r.rtt_s, r.compute_s, r.engagement, r.data_age_s);
  for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",{}", r.passivity_observed_J[i]);
  for (int i = 0; i < dof; ++i) fmt::format_to(std::back_inserter(out), ",{}", r.passivity_damping_Ns_per_m[i]);
  fmt::format_to(std::back_inserter(out), ",{},{},{},{}", r.device_warnings, r.clutch, r.fixture_stiffness_N_per_m,
                 r.fixture_limit_N_per_m);
  for (int i = 0; i < joints; ++i) fmt::format_to(std::back_inserter(out), ",{}", r.joint_position_rad[i]);
  for (int i = 0; i < joints; ++i) fmt::format_to(std::back_inserter(out), ",{}", r.joint_torque_Nm[i]);
  return fmt::to_string(out);
}

TelemetryWriter::TelemetryWriter(const std::string& csv_path, std::size_t ring_capacity, int dof, int joints)
    : path_(csv_path), dof_(dof), joints_(joints), ring_(std::max<std::size_t>(ring_capacity, 1)) {
  if (ring_capacity == 0) throw Error("telemetry: ring_capacity must be at least 1 record");
  if (dof < 0 || dof > kMaxDof) {
    throw Error("telemetry: dof " + std::to_string(dof) + " is outside 1.." + std::to_string(kMaxDof) +
                " (0 = from the first record)");
  }
  if (joints < 0 || joints > kMaxDof) {
    throw Error("telemetry: joints " + std::to_string(joints) + " is outside 0.." + std::to_string(kMaxDof));
  }
  file_ = std::fopen(csv_path.c_str(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    throw Error("telemetry: cannot open '" + csv_path + "' for writing: " + std::system_category().message(err) +
                "; check that the directory exists and is writable, or change telemetry.csv");
  }
  if (dof_ > 0) {
    WriteLine(TelemetryCsvHeader(dof_, joints_));
    header_written_ = true;
  }
  try {
    thread_ = std::thread([this] {
      BecomeBackgroundThread("teleop-telem");
      Drain();
    });
  } catch (...) {
    std::fclose(file_);
    throw;
  }
}

TelemetryWriter::~TelemetryWriter() {
  try {
    Stop();
  } catch (...) {
    // A destructor must not throw; Stop() only throws if the thread cannot be joined.
  }
}

void TelemetryWriter::WriteLine(const std::string& line) {
  const bool ok = std::fwrite(line.data(), 1, line.size(), file_) == line.size() && std::fputc('\n', file_) != EOF;
  if (!ok) write_errors_.fetch_add(1, std::memory_order_relaxed);
}

void TelemetryWriter::Drain() {
  TelemetryRecord record;
  while (true) {
    // Read the flag before draining: everything pushed before Stop() is in the ring by then.
    const bool stopping = stop_.load(std::memory_order_acquire);
    std::uint64_t drained = 0;
    while (ring_.TryPop(record)) {
      if (!header_written_) {
        dof_ = ClampDof(record.dof);
        joints_ = ClampJoints(record.joints);
        WriteLine(TelemetryCsvHeader(dof_, joints_));
        header_written_ = true;
      }
      WriteLine(TelemetryCsvRow(record, dof_, joints_));
      written_.fetch_add(1, std::memory_order_relaxed);
      ++drained;
    }
    if (stopping) break;
    if (drained == 0) std::this_thread::sleep_for(kDrainInterval);
  }
  if (!header_written_) {
    WriteLine(TelemetryCsvHeader(kMaxDof));
    header_written_ = true;
  }
}

void TelemetryWriter::Stop() {
  if (!thread_.joinable()) return;
  stop_.store(true, std::memory_order_release);
  thread_.join();
  if (std::fflush(file_) != 0) write_errors_.fetch_add(1, std::memory_order_relaxed);
  if (std::fclose(file_) != 0) write_errors_.fetch_add(1, std::memory_order_relaxed);
  file_ = nullptr;
  if (dropped() > 0) {
    spdlog::warn(
        "telemetry: {} of {} records dropped because the ring ({} records) was full; raise "
        "telemetry.ring_capacity or telemetry.decimation",
        dropped(), dropped() + pushed(), capacity());
  }
  if (write_errors() > 0) {
    spdlog::warn("telemetry: {} write errors on '{}' (disk full?); the CSV is incomplete", write_errors(), path_);
  }
}

}  // namespace teleop::runtime
