#include "teleop/config/stability_check.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>

#include "teleop/analysis/human_bounds.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/proto/can/bus_load.hpp"
#include "teleop/transport/can_bus_budget.hpp"

namespace teleop::config {

namespace {

using analysis::DeviceModel;
using analysis::FixtureSide;
using analysis::SampledTeleoperator;

DeviceModel PaperDevice(Role role) noexcept {
  return role == Role::kMaster ? analysis::kPaperMasterDevice : analysis::kPaperSlaveDevice;
}

Role Other(Role role) noexcept { return role == Role::kMaster ? Role::kSlave : Role::kMaster; }

double At(const std::optional<DofVector>& override_value, const DofVector& own, int axis) {
  return override_value ? (*override_value)[axis] : own[axis];
}

bool SameModel(const SampledTeleoperator& a, const SampledTeleoperator& b) noexcept {
  const analysis::LawGains& g = a.gains;
  const analysis::LawGains& h = b.gains;
  return a.master.mass_kg == b.master.mass_kg && a.master.damping_Ns_per_m == b.master.damping_Ns_per_m &&
         a.slave.mass_kg == b.slave.mass_kg && a.slave.damping_Ns_per_m == b.slave.damping_Ns_per_m &&
         g.kpm_N_per_m == h.kpm_N_per_m && g.kps_N_per_m == h.kps_N_per_m && g.kdm_Ns_per_m == h.kdm_Ns_per_m &&
         g.kds_Ns_per_m == h.kds_Ns_per_m && g.kvm_Ns_per_m == h.kvm_Ns_per_m && g.kvs_Ns_per_m == h.kvs_Ns_per_m &&
         g.kfm == h.kfm && g.master_fixture_N_per_m == h.master_fixture_N_per_m &&
         g.slave_fixture_N_per_m == h.slave_fixture_N_per_m && a.rate_hz == b.rate_hz &&
         a.velocity_filter_hz == b.velocity_filter_hz && a.peer_delay_samples == b.peer_delay_samples &&
         a.peer_delay_fraction == b.peer_delay_fraction && a.slave_peer_delay_samples == b.slave_peer_delay_samples &&
         a.slave_peer_delay_fraction == b.slave_peer_delay_fraction && a.unilateral == b.unilateral;
}

/// N/m values are printed whole: "4120 N/m".
std::string Whole(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f", value);
  return text;
}

std::string Plain(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

std::string Short(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

std::string Assumptions(const ProcessConfig& config, const SampledTeleoperator& system, int operators) {
  const DeviceModel& peer = config.role == Role::kMaster ? system.slave : system.master;
  std::ostringstream out;
  out << Plain(system.rate_hz) << " Hz, " << (system.unilateral ? "unilateral" : "bilateral") << ", "
      << analysis::DescribePeerDelay(system);
  if (system.slave_peer_delay_fraction && !system.slave_peer_delay_samples) {
    out << " (triggered: the slave sees the master's sample " << Short(*system.slave_peer_delay_fraction)
        << " of a period late)";
  }
  out << ", peer " << ToString(Other(config.role)) << " " << Short(peer.mass_kg) << " kg "
      << Short(peer.damping_Ns_per_m) << " N·s/m with fixture "
      << Whole(system.gains.fixture(FixtureSideOf(Other(config.role)))) << " N/m, " << operators
      << " operators; assumed " << DescribeAssumedLinkDelay(config);
  return out.str();
}

std::string Operator(const analysis::HumanModel& h) {
  return "m=" + Short(h.mass_kg) + " kg b=" + Short(h.damping_Ns_per_m) + " N·s/m k=" + Short(h.stiffness_N_per_m) +
         " N/m";
}

}  // namespace

analysis::FixtureSide FixtureSideOf(Role role) noexcept {
  return role == Role::kMaster ? FixtureSide::kMaster : FixtureSide::kSlave;
}

double TriggeredDataAge_s(const ProcessConfig& config) {
  if (config.link.transport != "can" && config.link.transport != "emulated-can") return kTriggeredDataAge_s;
  transport::CanLinkConfig can = config.link.can;
  can.dof = config.dof;
  const proto::can::BusLoad load =
      proto::can::ComputeBusLoad(transport::WireFormatOf(can), transport::BitratesOf(can), config.loop.rate_hz);
  return kTriggeredDataAge_s + load.cycle_complete_s;
}

SampledTeleoperator StabilityModel(const ProcessConfig& config, int axis) {
  if (axis < 0 || axis >= config.law.dof) {
    throw Error("stability model: axis " + std::to_string(axis) + " is outside 0.." +
                std::to_string(config.law.dof - 1));
  }
  const StabilityConfig& st = config.stability;
  const control::ThreeChannelLaw::Config& law = config.law;
  const FixtureSide side = FixtureSideOf(config.role);
  const FixtureSide peer_side = FixtureSideOf(Other(config.role));

  if (const std::string why = StabilityNotApplicable(config); !why.empty()) {
    throw Error("stability model: not applicable: " + why);
  }
  DeviceModel own = PaperDevice(config.role);
  if (const device::AnalysisModel model = device::DeviceModel(config.device); model.applicable) {
    own = {model.mass_kg[axis], model.damping_Ns_per_m[axis]};
  }
  if (st.device.mass_kg) own.mass_kg = *st.device.mass_kg;
  if (st.device.damping_Ns_per_m) own.damping_Ns_per_m = *st.device.damping_Ns_per_m;
  DeviceModel peer = PaperDevice(Other(config.role));
  if (st.peer.mass_kg) peer.mass_kg = *st.peer.mass_kg;
  if (st.peer.damping_Ns_per_m) peer.damping_Ns_per_m = *st.peer.damping_Ns_per_m;

  const auto too_short = [axis](const DofVector& v) { return v.size() <= axis; };
  if (too_short(law.kp_N_per_m) || too_short(law.kd_Ns_per_m) || too_short(law.kv_Ns_per_m) || too_short(law.kf) ||
      (st.peer.kp_N_per_m && too_short(*st.peer.kp_N_per_m)) ||
      (st.peer.kd_Ns_per_m && too_short(*st.peer.kd_Ns_per_m)) ||
      (st.peer.kv_Ns_per_m && too_short(*st.peer.kv_Ns_per_m)) || (st.peer.kf && too_short(*st.peer.kf))) {
    throw Error("stability model: a law or stability.peer gain has fewer than dof = " + std::to_string(law.dof) +
                " entries");
  }
  const double kp = law.kp_N_per_m[axis];
  const double kd = law.kd_Ns_per_m[axis];
  const double kv = law.kv_Ns_per_m[axis];
  const double kf = law.kf[axis];
  const double peer_kp = At(st.peer.kp_N_per_m, law.kp_N_per_m, axis);
  const double peer_kd = At(st.peer.kd_Ns_per_m, law.kd_Ns_per_m, axis);
  const double peer_kv = At(st.peer.kv_Ns_per_m, law.kv_Ns_per_m, axis);
  const double peer_kf = At(st.peer.kf, law.kf, axis);

  SampledTeleoperator s;
  s.rate_hz = config.loop.rate_hz;
  s.velocity_filter_hz = law.velocity_filter_hz;
  s.peer_delay_samples = st.peer_delay_samples;
  // A triggered pair: the slave computes right after the master's sample arrives, so its law sees that sample a
  // fraction of a period old (the measured or assumed data age); the master uses the reply at its next cycle (one
  // sample). Only with the whole-sample model (peer_delay_samples 1) that it refines.
  if (config.loop.sync == runtime::CycleSync::kTriggered && st.peer_delay_samples == 1) {
    s.slave_peer_delay_fraction =
        st.peer_delay_fraction.value_or(std::min(1.0, TriggeredDataAge_s(config) * config.loop.rate_hz));
  }
  s.unilateral = st.unilateral;
  analysis::LawGains& g = s.gains;
  // One side's gains into the model; eq. 9 (slave) has no K_f.
  const auto set_gains = [&g](Role r, double p, double d, double v, double f) {
    if (r == Role::kMaster) {
      g.kpm_N_per_m = p;
      g.kdm_Ns_per_m = d;
      g.kvm_Ns_per_m = v;
      g.kfm = f;
    } else {
      g.kps_N_per_m = p;
      g.kds_Ns_per_m = d;
      g.kvs_Ns_per_m = v;
    }
  };
  const Role peer_role = config.role == Role::kMaster ? Role::kSlave : Role::kMaster;
  set_gains(config.role, kp, kd, kv, kf);
  set_gains(peer_role, peer_kp, peer_kd, peer_kv, peer_kf);
  s.master = config.role == Role::kMaster ? own : peer;
  s.slave = config.role == Role::kMaster ? peer : own;
  // The fixture acts along `axis` when a plane's normal has a component on it (a stiffness without planes renders
  // nothing). Along the normal of a diagonal plane the analysis per axis is exact when the axes share their gains.
  bool fixture_on_axis = false;
  for (int p = 0; p < law.fixture.plane_count; ++p) {
    const DofVector& normal = law.fixture.planes[static_cast<std::size_t>(p)].normal;
    if (axis < normal.size() && normal[axis] != 0.0) fixture_on_axis = true;
  }
  g.fixture(side) = fixture_on_axis ? law.fixture.stiffness_N_per_m : 0.0;
  g.fixture(peer_side) = st.peer.fixture_stiffness_N_per_m;
  analysis::Validate(s);
  if (const double link_delay_s = AssumedLinkDelay_s(config); link_delay_s > 0.0) {
    try {
      analysis::AddLinkDelay(s, link_delay_s);
    } catch (const Error& e) {
      throw Error("stability model: link delay " + Plain(link_delay_s * 1e3) + " ms at " + Plain(s.rate_hz) +
                  " Hz is beyond the analysis' " + std::to_string(analysis::kMaxPeerDelaySamples) +
                  " samples: " + e.what());
    }
  }
  return s;
}

double AssumedLinkDelay_s(const ProcessConfig& config) noexcept {
  if (config.link.expected_delay_ms) return *config.link.expected_delay_ms * 1e-3;
  if (config.link.emulate.enabled) {
    const transport::ImpairmentConfig& e = config.link.emulate.impairments;
    return e.delay_s + e.jitter_s;
  }
  return 0.0;
}

std::string DescribeAssumedLinkDelay(const ProcessConfig& config) {
  if (config.link.expected_delay_ms) return "link.expected_delay_ms " + Plain(*config.link.expected_delay_ms) + " ms";
  if (config.link.emulate.enabled) {
    return "the emulated link's delay + jitter " + Plain(AssumedLinkDelay_s(config) * 1e3) +
           " ms (link.emulate; link.expected_delay_ms overrides)";
  }
  return "no link delay (link.expected_delay_ms absent)";
}

std::vector<analysis::HumanModel> StabilityOperators(const ProcessConfig& config) {
  const StabilityConfig& st = config.stability;
  if (st.human_bounds.empty()) return analysis::MakeHumanGrid(analysis::DefaultFingerBounds(), st.human_grid_steps);
  return analysis::MakeHumanGrid(analysis::LoadHumanBounds(BesideConfigFile(config.source_path, st.human_bounds)),
                                 st.human_grid_steps);
}

std::string StabilityNotApplicable(const ProcessConfig& config) {
  if (config.stability.device.mass_kg && config.stability.device.damping_Ns_per_m) return {};
  const device::AnalysisModel model = device::DeviceModel(config.device);
  if (model.applicable) return {};
  return "device '" + config.device.backend + "': " + model.reason;
}

bool StabilityReport::stable() const noexcept {
  if (!applicable()) return true;
  if (sweep && !sweep->check.stable) return false;
  for (const analysis::FixtureCheck& check : axes) {
    if (!check.stable) return false;
  }
  return !axes.empty();
}

int StabilityReport::worst_axis() const noexcept {
  // A failing axis is worse than a passing one; among equals, the smaller limit - stiffness is worse.
  const auto worse = [](const analysis::FixtureCheck& a, const analysis::FixtureCheck& b) {
    if (a.stable != b.stable) return !a.stable;
    return a.limit.max_stable_stiffness_N_per_m - a.stiffness_N_per_m <
           b.limit.max_stable_stiffness_N_per_m - b.stiffness_N_per_m;
  };
  std::size_t worst = 0;
  for (std::size_t i = 1; i < axes.size(); ++i) {
    if (worse(axes[i], axes[worst])) worst = i;
  }
  return static_cast<int>(worst);
}

namespace {

/// The device's sweep over the configurations near each fixture plane (ConfigurationSweep), or nothing.
std::optional<ConfigurationSweep> SweepConfigurations(const ProcessConfig& config,
                                                      std::span<const analysis::HumanModel> humans) {
  const control::ForbiddenRegionFixture::Config& fixture = config.law.fixture;
  const StabilityConfig& st = config.stability;
  if (!(fixture.stiffness_N_per_m > 0.0) || fixture.plane_count == 0) return std::nullopt;
  if (st.device.mass_kg && st.device.damping_Ns_per_m) return std::nullopt;  // the config's model wins
  const device::DeviceBackend* backend = device::FindDevice(config.device.backend);
  if (backend == nullptr || !backend->sweep) return std::nullopt;
  const auto start = std::chrono::steady_clock::now();
  const FixtureSide side = FixtureSideOf(config.role);
  std::optional<ConfigurationSweep> result;
  double smallest = std::numeric_limits<double>::infinity();
  SampledTeleoperator worst_model;
  int analysed = 0;
  std::string summaries;
  for (int p = 0; p < fixture.plane_count; ++p) {
    const control::FixturePlane& plane = fixture.planes[static_cast<std::size_t>(p)];
    const device::AnalysisSweep sweep = backend->sweep(config.device, plane.normal, plane.offset_m);
    if (sweep.configurations.empty() && sweep.summary.empty()) continue;
    summaries += (summaries.empty() ? "" : "; ") + ("plane " + std::to_string(p) + ": " + sweep.summary);
    int axis = 0;
    plane.normal.cwiseAbs().maxCoeff(&axis);
    const SampledTeleoperator base = StabilityModel(config, axis);
    for (const device::AnalysisConfiguration& c : sweep.configurations) {
      SampledTeleoperator model = base;
      (config.role == Role::kMaster ? model.master : model.slave) = {c.mass_kg, c.damping_Ns_per_m};
      // The ranking to 1 %; the worst configuration's limit is then found to the default 0.1 % by CheckFixture.
      analysis::LimitOptions options;
      options.relative_tolerance = 1e-2;
      const analysis::StabilityLimit limit = analysis::FindMaxStableStiffness(model, side, humans, options);
      ++analysed;
      if (!result || limit.max_stable_stiffness_N_per_m < smallest) {
        smallest = limit.max_stable_stiffness_N_per_m;
        if (!result) result.emplace();
        result->plane = p;
        result->axis = axis;
        result->worst = c;
        worst_model = model;
      }
    }
  }
  if (!result) return std::nullopt;
  result->summary = summaries;
  result->analysed = analysed;
  result->check = analysis::CheckFixture(worst_model, side, humans);
  result->elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::string DescribeWorstConfiguration(const ConfigurationSweep& s) {
  std::ostringstream out;
  out << "at the worst of " << s.analysed << " configurations near fixture plane " << s.plane << ": " << s.worst.where
      << ", apparent mass " << Short(s.worst.mass_kg) << " kg and damping " << Short(s.worst.damping_Ns_per_m)
      << " N·s/m along the normal (" << s.summary << "; " << Whole(s.elapsed_ms) << " ms)";
  return out.str();
}

}  // namespace

StabilityReport CheckProcessStability(const ProcessConfig& config, std::span<const analysis::HumanModel> humans) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<analysis::HumanModel> own_humans;
  if (humans.empty() && StabilityNotApplicable(config).empty()) {
    own_humans = StabilityOperators(config);
    humans = own_humans;
  }
  StabilityReport report;
  report.not_applicable = StabilityNotApplicable(config);
  if (!report.applicable()) return report;
  report.operators = static_cast<int>(humans.size());
  std::vector<SampledTeleoperator> models;
  for (int axis = 0; axis < config.law.dof; ++axis) {
    const SampledTeleoperator model = StabilityModel(config, axis);
    bool reused = false;
    for (std::size_t i = 0; i < models.size(); ++i) {
      if (SameModel(models[i], model)) {
        report.axes.push_back(report.axes[i]);
        reused = true;
        break;
      }
    }
    if (!reused) report.axes.push_back(analysis::CheckFixture(model, FixtureSideOf(config.role), humans));
    models.push_back(model);
  }
  report.sweep = SweepConfigurations(config, humans);
  report.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

std::string DescribePass(const ProcessConfig& config, const StabilityReport& report) {
  if (!report.applicable()) {
    return "stability check not applicable: " + report.not_applicable +
           "; the fixture stiffness is NOT checked (give stability.device.mass_kg and damping_Ns_per_m to check it "
           "against a mass-damper model of this device)";
  }
  const int axis = report.worst_axis();
  const analysis::FixtureCheck& c = report.worst();
  const double limit = c.limit.max_stable_stiffness_N_per_m;
  std::ostringstream out;
  out << "stability check passed: " << ToString(config.role) << " fixture " << Whole(c.stiffness_N_per_m)
      << " N/m, predicted limit " << Whole(limit) << " N/m";
  if (c.stiffness_N_per_m > 0.0) {
    out << " (margin " << Whole(100.0 * (1.0 - c.stiffness_N_per_m / limit)) << " %, limit/stiffness "
        << Short(limit / c.stiffness_N_per_m) << ")";
  } else {
    out << " (no fixture; the coupling alone is stable)";
  }
  if (config.law.dof > 1) out << " on axis " << axis << " (smallest margin of " << config.law.dof << " DOF)";
  out << "; worst damping ratio " << Short(c.at_configured.min_damping_ratio) << " for operator "
      << Operator(c.at_configured.human) << "; " << Assumptions(config, StabilityModel(config, axis), report.operators)
      << "; " << Whole(report.elapsed_ms) << " ms";
  if (report.sweep) {
    const analysis::FixtureCheck& w = report.sweep->check;
    out << "; over the arm's configurations: predicted limit " << Whole(w.limit.max_stable_stiffness_N_per_m) << " N/m "
        << DescribeWorstConfiguration(*report.sweep);
  }
  return out.str();
}

std::string DescribeFailure(const ProcessConfig& config, const StabilityReport& report) {
  // The sweep's refusal names the arm's worst configuration, unless the coupling itself is unstable on an axis.
  bool coupling_unstable = false;
  for (const analysis::FixtureCheck& check : report.axes) coupling_unstable |= check.limit.unstable_without_fixture;
  if (!coupling_unstable && report.sweep && !report.sweep->check.stable) {
    const ConfigurationSweep& s = *report.sweep;
    const double limit = s.check.limit.max_stable_stiffness_N_per_m;
    std::ostringstream out;
    out << config.source_path << ": " << ToString(config.role) << " fixture " << Whole(s.check.stiffness_N_per_m)
        << " N/m is above the predicted stability limit " << Whole(limit) << " N/m " << DescribeWorstConfiguration(s)
        << " (axis " << s.axis << "'s gains, worst damping ratio " << Short(s.check.at_configured.min_damping_ratio)
        << " for operator " << Operator(s.check.at_configured.human) << "). Lower fixture.stiffness_N_per_m to at most "
        << Whole(std::floor(limit))
        << " N/m, move the plane, or raise rate_hz or law.kd_Ns_per_m (try it with teleop-arm check --config "
        << config.source_path << ")";
    return out.str();
  }
  const int axis = report.worst_axis();
  const analysis::FixtureCheck& c = report.worst();
  const SampledTeleoperator model = StabilityModel(config, axis);
  const double limit = c.limit.max_stable_stiffness_N_per_m;
  std::ostringstream out;
  out << config.source_path << ": ";
  if (c.limit.unstable_without_fixture) {
    out << "the " << ToString(config.role) << "'s coupling is predicted UNSTABLE even without a fixture (predicted "
        << "limit " << Whole(limit) << " N/m, configured fixture " << Whole(c.stiffness_N_per_m) << " N/m, ";
  } else {
    out << ToString(config.role) << " fixture " << Whole(c.stiffness_N_per_m)
        << " N/m is above the predicted stability limit " << Whole(limit) << " N/m (";
  }
  if (config.law.dof > 1) out << "axis " << axis << ", ";
  out << Assumptions(config, model, report.operators) << "; worst damping ratio "
      << Short(c.at_configured.min_damping_ratio) << " for operator " << Operator(c.at_configured.human) << "). ";
  if (c.limit.unstable_without_fixture) {
    out << "Raise rate_hz, raise law.kd_Ns_per_m or law.kv_Ns_per_m, or lower law.kp_N_per_m";
  } else {
    out << "Lower fixture.stiffness_N_per_m to at most " << Whole(std::floor(limit))
        << " N/m, or raise rate_hz or law.kd_Ns_per_m";
  }
  out << " (try it with teleop-analyze check --config " << config.source_path
      << "; with these values: " << AnalyzeCommandLine(config, axis) << ")";
  return out.str();
}

std::string AnalyzeCommandLine(const ProcessConfig& config, int axis) {
  const SampledTeleoperator s = StabilityModel(config, axis);
  const analysis::PeerDelays d = analysis::PeerDelaysOf(s);
  const analysis::LawGains g = s.gains;
  const FixtureSide side = FixtureSideOf(config.role);
  const auto exact = [](double value) {
    char text[40];
    std::snprintf(text, sizeof text, "%.10g", value);
    return std::string(text);
  };
  std::ostringstream out;
  out << "teleop-analyze max-stiffness --side " << analysis::ToString(side) << " --rate " << exact(s.rate_hz)
      << " --kpm " << exact(g.kpm_N_per_m) << " --kps " << exact(g.kps_N_per_m) << " --kdm " << exact(g.kdm_Ns_per_m)
      << " --kds " << exact(g.kds_Ns_per_m) << " --kvm " << exact(g.kvm_Ns_per_m) << " --kvs " << exact(g.kvs_Ns_per_m)
      << " --master-mass " << exact(s.master.mass_kg) << " --master-damping " << exact(s.master.damping_Ns_per_m)
      << " --slave-mass " << exact(s.slave.mass_kg) << " --slave-damping " << exact(s.slave.damping_Ns_per_m)
      << " --velocity-filter-hz " << exact(s.velocity_filter_hz) << " --peer-delay-samples "
      << d.slave_to_master_samples << " --peer-delay-fraction " << exact(d.slave_to_master_fraction)
      << " --slave-peer-delay-samples " << d.master_to_slave_samples << " --slave-peer-delay-fraction "
      << exact(d.master_to_slave_fraction) << " --other-fixture "
      << exact(g.fixture(side == FixtureSide::kMaster ? FixtureSide::kSlave : FixtureSide::kMaster));
  if (s.unilateral) out << " --unilateral";
  const StabilityConfig& st = config.stability;
  if (!st.human_bounds.empty()) out << " --human-bounds " << BesideConfigFile(config.source_path, st.human_bounds);
  out << " --human-steps " << st.human_grid_steps << "  # the limit; this fixture: " << exact(g.fixture(side))
      << " N/m";
  return out.str();
}

}  // namespace teleop::config
