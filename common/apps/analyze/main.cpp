// teleop-analyze: stability of forbidden-region virtual fixtures (Abbott & Okamura 2006). docs/stability.md.
//
//   teleop-analyze max-stiffness --side slave --rate 500 --kp 600 --kd 2 [--json]
//   teleop-analyze max-stiffness --side slave --kp 600 --kd 2 --link-delay-ms 40
//   teleop-analyze sweep --side slave --kp 600 --kd 2 --variable rate --values 250,500,1000 --output fig7
//   teleop-analyze sweep --side slave --kp 600 --kd 2 --over delay --values 0,10,40,100 --output by-delay
//   teleop-analyze check --config deploy/configs/slave.yaml
//
// The model defaults to what the processes run (peer data one sample old, the shipped configs' 200 Hz velocity
// filter) and says so; --paper-model gives the paper's (no delay, no filter).
//
// Exit codes: 0 success (check: stable), 1 check: unstable, max-stiffness: unstable even without a fixture (no
// stable stiffness), 2 bad arguments or input (max-stiffness: no limit below the search ceiling of 1e9 N/m).

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/analysis/discrete_model.hpp"
#include "teleop/analysis/fixture_check.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/limit_sweep.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "teleop/cli_help.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/version.hpp"

namespace {

using namespace teleop::analysis;

constexpr double kUnset = std::numeric_limits<double>::quiet_NaN();
constexpr int kExitUnstable = 1;
constexpr int kExitBadInput = 2;
constexpr double kDefaultRate_hz = 1000.0;
// The processes' model: the shipped configs' law.velocity_filter_hz (deploy/configs/*.yaml) and one sample of peer
// delay (stability.peer_delay_samples 1).
constexpr double kProcessFilter_hz = 200.0;

/// Options shared by the subcommands: the system and the operator set.
struct SystemOptions {
  std::string side = "slave";
  bool unilateral = false;
  double rate_hz = kDefaultRate_hz;
  double kp = 0.0;
  double kd = 0.0;
  double kpm = kUnset, kps = kUnset, kdm = kUnset, kds = kUnset;
  double kvm = 0.0, kvs = 0.0, kf = 0.0;
  double master_mass_kg = kPaperMasterDevice.mass_kg;
  double master_damping = kPaperMasterDevice.damping_Ns_per_m;
  double slave_mass_kg = kPaperSlaveDevice.mass_kg;
  double slave_damping = kPaperSlaveDevice.damping_Ns_per_m;
  double other_fixture = 0.0;
  std::vector<double> human_mass, human_damping, human_stiffness;
  std::string human_bounds;
  int human_steps = 4;
  double velocity_filter_hz = kProcessFilter_hz;
  int peer_delay_samples = 1;
  double peer_delay_fraction = 0.0;
  double slave_peer_delay_fraction = -1.0;  // < 0: as the master's
  int slave_peer_delay_samples = -1;        // < 0: as the master's
  double link_delay_ms = 0.0;
  bool paper_model = false;
  int threads = 0;
  bool json = false;
};

void AddSystemOptions(CLI::App& app, SystemOptions& o, bool with_side) {
  if (with_side) {
    app.add_option("--side", o.side, "Fixture analysed: master or slave")
        ->check(CLI::IsMember({"master", "slave"}))
        ->required();
  }
  app.add_flag("--unilateral", o.unilateral,
               "Master actuator renders nothing of the slave (K_pm = K_dm = K_fm = 0; slave side: master saturated)");
  app.add_flag("--paper-model", o.paper_model,
               "The paper's model (both laws see the same samples, no velocity filter) instead of the processes' "
               "(peer data one sample old, 200 Hz filter); excludes the delay and filter options");
  app.add_option("--rate", o.rate_hz, "Sampling rate (Hz)");
  app.add_option("--kp", o.kp, "K_p on both sides (N/m), symmetric law of §4.3");
  app.add_option("--kd", o.kd, "K_d on both sides (N·s/m)");
  app.add_option("--kpm", o.kpm, "K_pm (N/m), overrides --kp");
  app.add_option("--kps", o.kps, "K_ps (N/m), overrides --kp");
  app.add_option("--kdm", o.kdm, "K_dm (N·s/m), overrides --kd");
  app.add_option("--kds", o.kds, "K_ds (N·s/m), overrides --kd");
  app.add_option("--kvm", o.kvm, "K_vm, master velocity damping (N·s/m)");
  app.add_option("--kvs", o.kvs, "K_vs, slave velocity damping (N·s/m)");
  app.add_option("--kf", o.kf, "K_fm, force feed-forward (no effect: F_e = 0 in the analysis)");
  app.add_option("--master-mass", o.master_mass_kg, "Master mass (kg; default: paper §4.1)");
  app.add_option("--master-damping", o.master_damping, "Master damping (N·s/m)");
  app.add_option("--slave-mass", o.slave_mass_kg, "Slave mass (kg)");
  app.add_option("--slave-damping", o.slave_damping, "Slave damping (N·s/m)");
  app.add_option("--other-fixture", o.other_fixture, "Stiffness of the other side's fixture, held fixed (N/m)");
  auto* mass = app.add_option("--human-mass", o.human_mass, "Operator masses (kg), comma-separated")->delimiter(',');
  auto* damping =
      app.add_option("--human-damping", o.human_damping, "Operator dampings (N·s/m), comma-separated")->delimiter(',');
  auto* stiffness =
      app.add_option("--human-stiffness", o.human_stiffness, "Operator stiffnesses (N/m), comma-separated")
          ->delimiter(',');
  auto* bounds = app.add_option("--human-bounds", o.human_bounds,
                                "CSV of operator bounds per force level (deploy/configs/human_bounds_finger.csv)");
  mass->needs(damping)->needs(stiffness);
  damping->needs(mass)->needs(stiffness);
  stiffness->needs(mass)->needs(damping);
  bounds->excludes(mass)->excludes(damping)->excludes(stiffness);
  app.add_option("--human-steps", o.human_steps, "Grid points per parameter between the bounds (4: 512 operators)")
      ->check(CLI::Range(1, 64));
  auto* filter = app.add_option("--velocity-filter-hz", o.velocity_filter_hz,
                                "First-order velocity low-pass (Hz), 0 = none; the shipped configs' 200 Hz");
  auto* samples = app.add_option("--peer-delay-samples", o.peer_delay_samples,
                                 "Whole samples of peer data age: 0 the paper's model, 1 the processes over a link, "
                                 "up to " +
                                     std::to_string(kMaxPeerDelaySamples) +
                                     " (slave->master, and master->slave unless --slave-peer-delay-*)")
                      ->check(CLI::Range(0, kMaxPeerDelaySamples));
  filter->excludes("--paper-model");
  samples->excludes("--paper-model");
  if (with_side) {
    app.add_option("--peer-delay-fraction", o.peer_delay_fraction,
                   "Peer data age beyond the whole samples as a fraction of the period (0..1, ZOH with a "
                   "fractional input delay; with --peer-delay-samples 0: a phase-locked pair)")
        ->check(CLI::Range(0.0, 1.0))
        ->excludes("--paper-model");
    app.add_option("--slave-peer-delay-samples", o.slave_peer_delay_samples,
                   "master->slave: the slave sees the master's sample this many whole samples late (-1: as "
                   "--peer-delay-samples, or 0 with --slave-peer-delay-fraction)")
        ->check(CLI::Range(-1, kMaxPeerDelaySamples))
        ->excludes("--paper-model");
    app.add_option("--slave-peer-delay-fraction", o.slave_peer_delay_fraction,
                   "master->slave: and this fraction of a period (0..1; a triggered pair, sync.mode triggered, "
                   "sets only this; -1: as the master's)")
        ->check(CLI::Range(-1.0, 1.0))
        ->excludes("--paper-model");
  }
  app.add_option("--link-delay-ms", o.link_delay_ms,
                 "A link's one-way delay (ms) added to both directions on top of the model's own (the processes' "
                 "one sample): what the start-up check does with link.expected_delay_ms")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--threads", o.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 64));
  app.add_flag("--json", o.json, "Print a JSON object instead of the plain number");
}

FixtureSide SideOf(const std::string& side) { return side == "master" ? FixtureSide::kMaster : FixtureSide::kSlave; }

double Or(double value, double fallback) { return std::isnan(value) ? fallback : value; }

SampledTeleoperator BuildSystem(const SystemOptions& o, FixtureSide side) {
  SampledTeleoperator s;
  s.master = {o.master_mass_kg, o.master_damping};
  s.slave = {o.slave_mass_kg, o.slave_damping};
  s.rate_hz = o.rate_hz;
  s.velocity_filter_hz = o.paper_model ? 0.0 : o.velocity_filter_hz;
  s.peer_delay_samples = o.paper_model ? 0 : o.peer_delay_samples;
  s.peer_delay_fraction = o.paper_model ? 0.0 : o.peer_delay_fraction;
  if (o.slave_peer_delay_fraction >= 0.0) s.slave_peer_delay_fraction = o.slave_peer_delay_fraction;
  if (o.slave_peer_delay_samples >= 0) s.slave_peer_delay_samples = o.slave_peer_delay_samples;
  s.unilateral = o.unilateral;
  LawGains& g = s.gains;
  g.kpm_N_per_m = Or(o.kpm, o.kp);
  g.kps_N_per_m = Or(o.kps, o.kp);
  g.kdm_Ns_per_m = Or(o.kdm, o.kd);
  g.kds_Ns_per_m = Or(o.kds, o.kd);
  g.kvm_Ns_per_m = o.kvm;
  g.kvs_Ns_per_m = o.kvs;
  g.kfm = o.kf;
  g.fixture(side == FixtureSide::kMaster ? FixtureSide::kSlave : FixtureSide::kMaster) = o.other_fixture;
  Validate(s);
  if (o.link_delay_ms > 0.0) AddLinkDelay(s, o.link_delay_ms * 1e-3);
  return s;
}

/// Which model the answer is for, in words (printed with every answer: 30.4, one analysis answer).
std::string ModelNote(const SystemOptions& o, const SampledTeleoperator& s) {
  std::ostringstream out;
  out << (o.paper_model ? "the paper's model (" : "the processes' model (") << DescribePeerDelay(s);
  if (o.link_delay_ms > 0.0) out << " with a " << o.link_delay_ms << " ms link";
  out << ", velocity filter ";
  if (s.velocity_filter_hz > 0.0) {
    out << s.velocity_filter_hz << " Hz";
  } else {
    out << "none";
  }
  out << ", " << s.rate_hz << " Hz";
  if (NeedsDelayLines(s)) out << ", " << DelayedStateDimension(s) << " states";
  out << ")"
      << (o.paper_model ? "; without --paper-model: the processes' (one sample of peer delay, 200 Hz filter)"
                        : "; --paper-model for the paper's (no delay, no filter)");
  return out.str();
}

std::vector<HumanModel> BuildHumans(const SystemOptions& o) {
  if (!o.human_mass.empty()) return MakeHumanGrid(o.human_mass, o.human_damping, o.human_stiffness);
  if (!o.human_bounds.empty()) return MakeHumanGrid(LoadHumanBounds(o.human_bounds), o.human_steps);
  return MakeHumanGrid(DefaultFingerBounds(), o.human_steps);
}

std::string HumanJson(const HumanModel& h) {
  std::ostringstream out;
  out.precision(10);
  out << "{\"mass_kg\": " << h.mass_kg << ", \"damping_Ns_per_m\": " << h.damping_Ns_per_m
      << ", \"stiffness_N_per_m\": " << h.stiffness_N_per_m << ", \"force_N\": " << h.force_N << "}";
  return out.str();
}

std::string LimitJson(const StabilityLimit& l, const SampledTeleoperator& s, FixtureSide side, std::size_t operators) {
  std::ostringstream out;
  out.precision(10);
  out << "{\n  \"side\": \"" << ToString(side) << "\",\n  \"rate_hz\": " << s.rate_hz
      << ",\n  \"unilateral\": " << (s.unilateral ? "true" : "false")
      << ",\n  \"peer_delay_samples\": " << s.peer_delay_samples
      << ",\n  \"slave_to_master_delay_samples\": " << PeerDelaysOf(s).slave_to_master()
      << ",\n  \"master_to_slave_delay_samples\": " << PeerDelaysOf(s).master_to_slave()
      << ",\n  \"state_dimension\": " << (NeedsDelayLines(s) ? DelayedStateDimension(s) : kModelStates)
      << ",\n  \"peer_delay_fraction\": " << s.peer_delay_fraction << ",\n  \"slave_peer_delay_fraction\": "
      << (s.slave_peer_delay_fraction ? std::to_string(*s.slave_peer_delay_fraction) : std::string("null"))
      << ",\n  \"velocity_filter_hz\": " << s.velocity_filter_hz
      << ",\n  \"max_stable_stiffness_N_per_m\": " << l.max_stable_stiffness_N_per_m
      << ",\n  \"min_unstable_stiffness_N_per_m\": " << l.min_unstable_stiffness_N_per_m
      << ",\n  \"worst_damping_ratio\": " << l.worst_damping_ratio
      << ",\n  \"worst_human\": " << HumanJson(l.worst_human)
      << ",\n  \"limiting_human\": " << HumanJson(l.limiting_human)
      << ",\n  \"passivity_bound_N_per_m\": " << l.passivity_bound_N_per_m
      << ",\n  \"unstable_without_fixture\": " << (l.unstable_without_fixture ? "true" : "false")
      << ",\n  \"operators\": " << operators << ",\n  \"models_evaluated\": " << l.models_evaluated << "\n}";
  return out.str();
}

int RunMaxStiffness(const SystemOptions& o) {
  const FixtureSide side = SideOf(o.side);
  const SampledTeleoperator system = BuildSystem(o, side);
  const std::vector<HumanModel> humans = BuildHumans(o);
  LimitOptions options;
  options.threads = o.threads;
  const auto start = std::chrono::steady_clock::now();
  const StabilityLimit limit = FindMaxStableStiffness(system, side, humans, options);
  const double elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // The model on stderr (stdout stays the number a script reads), with the cost of the answer.
  std::cerr << "teleop-analyze: " << ModelNote(o, system) << "; " << humans.size() << " operators, "
            << limit.models_evaluated << " models in " << static_cast<long>(std::lround(elapsed_ms)) << " ms\n";
  // Two results that are not a limit: print why instead of a number a script would take for one.
  if (limit.unstable_without_fixture) {
    std::cerr << "teleop-analyze: no fixture stiffness is stable: the coupling alone (no fixture) is predicted "
                 "UNSTABLE for these gains at "
              << system.rate_hz << " Hz (K_p master " << system.gains.kpm_N_per_m << " N/m, slave "
              << system.gains.kps_N_per_m << " N/m); lower --kp, raise --kd or --rate\n";
    return kExitUnstable;
  }
  if (!std::isfinite(limit.max_stable_stiffness_N_per_m) ||
      limit.max_stable_stiffness_N_per_m >= options.max_stiffness_N_per_m) {
    std::cerr << "teleop-analyze: no limit found: the model stays stable up to the search ceiling "
              << options.max_stiffness_N_per_m
              << " N/m, which no real device renders; check the operator and device parameters (masses, dampings, "
                 "--human-* or --human-bounds) for values far outside the physical range\n";
    return kExitBadInput;
  }
  if (o.json) {
    std::string json = LimitJson(limit, system, side, humans.size());
    json.insert(json.size() - 2, ",\n  \"model\": \"" + std::string(o.paper_model ? "paper" : "process") +
                                     "\",\n  \"elapsed_ms\": " + std::to_string(elapsed_ms));
    std::cout << json << "\n";
  } else {
    std::printf("%.6g\n", limit.max_stable_stiffness_N_per_m);
  }
  return 0;
}

struct SweepOptions {
  std::string variable = "rate";
  std::vector<double> values;
  std::string output = "stability_sweep";
  bool no_plot = false;
};

void Plot(const std::string& csv, const std::string& png, SweepVariable variable, const std::string& title) {
  const std::string script_path = png + ".gp";
  {
    std::ofstream gp(script_path);
    const char* xlabel = variable == SweepVariable::kRateHz ? "sampling rate (Hz)"
                         : variable == SweepVariable::kKp   ? "K_p (N/m)"
                         : variable == SweepVariable::kKd   ? "K_d (N s/m)"
                                                            : "link delay, one way (ms)";
    // The key below the plot, never over the curves (a K_p sweep rises and falls), one entry a line so that its
    // samples stay inside the canvas, with a bottom margin that holds the tick labels, the x label and the key (else
    // gnuplot draws the key against the x label); the end points clear of the left and right axes; cairo for text.
    gp << "set terminal pngcairo size 800,600 font ',11'\nset output '" << png << "'\nset datafile separator ','\n"
       << "set title '" << title << "' noenhanced\nset xlabel '" << xlabel
       << "'\nset ylabel 'maximum stable fixture stiffness (N/m)'\nset key outside bottom center vertical\nset bmargin "
          "6\n"
       << "set yrange [0:*]\nset offsets graph 0.03, graph 0.03, 0, 0\nset grid\n"
       << "plot '" << csv << "' skip 1 using 1:2 with linespoints title 'eigenvalue limit (worst operator)', '" << csv
       << "' skip 1 using 1:3 with linespoints title 'passivity bound (Colgate-Schenkel)'\n";
  }
  const std::string command = "gnuplot '" + script_path + "' 2>&1";
  if (std::system(command.c_str()) != 0) {
    std::cerr << "teleop-analyze: gnuplot failed or is missing; the CSV is " << csv << " (script " << script_path
              << ")\n";
  }
}

int RunSweep(const SystemOptions& o, const SweepOptions& w) {
  const FixtureSide side = SideOf(o.side);
  const SweepVariable variable = ParseSweepVariable(w.variable);
  const SampledTeleoperator system = BuildSystem(o, side);
  const std::vector<HumanModel> humans = BuildHumans(o);
  LimitOptions options;
  options.threads = o.threads;
  const auto points = SweepLimit(system, side, humans, variable, w.values, options);
  const std::string csv = w.output + ".csv";
  {
    std::ofstream out(csv);
    if (!out) throw teleop::Error(csv + ": cannot write the sweep CSV");
    WriteSweepCsv(out, variable, points);
  }
  // The swept gain is named as swept (its base value is not used); the other gains with their units.
  std::ostringstream title;
  title << ToString(side) << " fixture, " << (system.unilateral ? "unilateral" : "bilateral") << ", ";
  if (variable == SweepVariable::kKp) {
    title << "K_p swept";
  } else {
    title << "K_pm " << system.gains.kpm_N_per_m << " K_ps " << system.gains.kps_N_per_m << " N/m";
  }
  if (variable == SweepVariable::kKd) {
    title << ", K_d swept";
  } else {
    title << ", K_dm " << system.gains.kdm_Ns_per_m << " K_ds " << system.gains.kds_Ns_per_m << " Ns/m";
  }
  if (variable != SweepVariable::kRateHz) title << ", " << system.rate_hz << " Hz";
  title << (o.paper_model ? ", paper model" : ", process model");  // no apostrophe: gnuplot's title string
  std::cerr << "teleop-analyze: " << ModelNote(o, system) << "\n";
  if (!w.no_plot) Plot(csv, w.output + ".png", variable, title.str());
  WriteSweepCsv(std::cout, variable, points);
  return 0;
}

/// Analyses the process's own fixture exactly as the process does at start-up (config::CheckProcessStability, with
/// the config's `stability:` section). Flags given on the command line override that section: the peer's gains
/// (--kps/--kds/--kvs for a master config, --kpm/--kdm/--kvm for a slave config), either device, the peer's fixture
/// (--other-fixture), --unilateral, --peer-delay-samples and the operator set.
int RunCheck(const SystemOptions& o, const CLI::App& app, const std::string& config_path) {
  namespace config = teleop::config;
  config::ProcessConfig process = config::LoadProcessConfig(config_path);
  config::StabilityConfig& st = process.stability;
  const bool master = process.role == teleop::Role::kMaster;
  const auto given = [&app](const char* flag) { return app.count(flag) > 0; };
  const auto dof_value = [&process](double value) { return teleop::DofVector::Constant(process.dof, value); };
  if (given(master ? "--kps" : "--kpm")) st.peer.kp_N_per_m = dof_value(master ? o.kps : o.kpm);
  if (given(master ? "--kds" : "--kdm")) st.peer.kd_Ns_per_m = dof_value(master ? o.kds : o.kdm);
  if (given(master ? "--kvs" : "--kvm")) st.peer.kv_Ns_per_m = dof_value(master ? o.kvs : o.kvm);
  if (given("--master-mass")) (master ? st.device.mass_kg : st.peer.mass_kg) = o.master_mass_kg;
  if (given("--master-damping")) (master ? st.device.damping_Ns_per_m : st.peer.damping_Ns_per_m) = o.master_damping;
  if (given("--slave-mass")) (master ? st.peer.mass_kg : st.device.mass_kg) = o.slave_mass_kg;
  if (given("--slave-damping")) (master ? st.peer.damping_Ns_per_m : st.device.damping_Ns_per_m) = o.slave_damping;
  if (given("--other-fixture")) st.peer.fixture_stiffness_N_per_m = o.other_fixture;
  if (o.unilateral) st.unilateral = true;
  if (given("--peer-delay-samples")) st.peer_delay_samples = o.peer_delay_samples;
  if (given("--human-bounds")) st.human_bounds = std::filesystem::absolute(o.human_bounds).string();
  if (given("--human-steps")) st.human_grid_steps = o.human_steps;
  std::vector<HumanModel> humans;
  if (!o.human_mass.empty()) humans = BuildHumans(o);

  const config::StabilityReport report = config::CheckProcessStability(process, humans);
  for (int axis = 0; axis < process.dof; ++axis) {
    const FixtureCheck& check = report.axes[static_cast<std::size_t>(axis)];
    if (o.json) {
      const SampledTeleoperator system = config::StabilityModel(process, axis);
      std::cout << "{\"axis\": " << axis << ", \"stable\": " << (check.stable ? "true" : "false")
                << ", \"stiffness_N_per_m\": " << check.stiffness_N_per_m
                << ", \"worst_damping_ratio_at_stiffness\": " << check.at_configured.min_damping_ratio
                << ", \"limit\": "
                << LimitJson(check.limit, system, check.side, static_cast<std::size_t>(report.operators)) << "}\n";
    } else {
      std::cout << config_path << " axis " << axis << ": " << check.message << "\n";
    }
  }
  if (!o.json && report.sweep) {
    const FixtureCheck& check = report.sweep->check;
    std::cout << config_path << " over the arm's configurations near the fixture (teleop-arm check --config): "
              << (check.stable ? "stable" : "UNSTABLE") << ", predicted limit "
              << check.limit.max_stable_stiffness_N_per_m << " N/m at " << report.sweep->worst.where
              << ", apparent mass " << report.sweep->worst.mass_kg << " kg, damping "
              << report.sweep->worst.damping_Ns_per_m << " N·s/m\n";
  }
  if (!o.json && !st.check) {
    std::cout << config_path << ": note: stability.check is false, the process will start without this check\n";
  }
  return report.stable() ? 0 : kExitUnstable;
}

}  // namespace

static int Run(int argc, char** argv) {
  CLI::App app{"Stability of forbidden-region virtual fixtures (Abbott & Okamura 2006): docs/stability.md"};
  app.set_version_flag("--version", teleop::VersionText("teleop-analyze"));
  app.require_subcommand(1);
  // Every default in --help (the subcommands inherit this).
  teleop::StandardHelp(app);

  SystemOptions max_options;
  CLI::App* max = app.add_subcommand("max-stiffness", "Maximum stable fixture stiffness over the operator set (N/m)");
  AddSystemOptions(*max, max_options, true);

  SystemOptions sweep_options;
  SweepOptions sweep;
  CLI::App* sweep_app = app.add_subcommand("sweep", "Limit against rate, K_p or K_d: CSV + PNG (paper Figs. 7-14)");
  AddSystemOptions(*sweep_app, sweep_options, true);
  sweep_app
      ->add_option("--variable,--over", sweep.variable,
                   "rate, kp, kd or delay (ms of one-way link delay added to both directions)")
      ->check(CLI::IsMember({"rate", "kp", "kd", "delay"}))
      ->required();
  sweep_app->add_option("--values", sweep.values, "Comma-separated values of the variable")->delimiter(',')->required();
  sweep_app->add_option("--output", sweep.output, "Output prefix: PREFIX.csv and PREFIX.png");
  sweep_app->add_flag("--no-plot", sweep.no_plot, "CSV only");

  SystemOptions check_options;
  std::string config_path;
  CLI::App* check = app.add_subcommand("check", "Analyse a process config's fixture: stable or not, with the limit");
  AddSystemOptions(*check, check_options, false);
  check->add_option("--config", config_path, "teleop-master/teleop-slave YAML config")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }
  try {
    if (*max) return RunMaxStiffness(max_options);
    if (*sweep_app) return RunSweep(sweep_options, sweep);
    if (*check) {
      return RunCheck(check_options, *check, config_path);
    }
  } catch (const teleop::Error& e) {
    std::cerr << "teleop-analyze: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "teleop-analyze: error: " << e.what() << "\n";
    return kExitBadInput;
  }
  return kExitBadInput;
}

int main(int argc, char** argv) {
  // Everything expected is handled in Run(); this only keeps an unexpected exception (e.g. out of memory while
  // setting up) from ending the program without a message.
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "teleop-analyze: unexpected error: " << e.what() << "\n";
    return 3;
  } catch (...) {
    std::cerr << "unexpected error\n";
    return 3;
  }
}
