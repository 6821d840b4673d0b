// passivity-delay-sweep: the delay demonstration of docs/stability.md ("Time-domain passivity"). Sweeps the
// one-way delay (in samples) of the lock-step closed loop (tests/test_utilities/closed_loop.hpp) on the paper's
// loopback plant for one gain set, with the plain law and with the passivity controller in each mode, and prints
// a table (and optionally a CSV and a gnuplot PNG): the oscillation amplitude early and late, the growth, the
// energy the network generated, what the controllers dissipated, and the first delay at which the plain law fails.
// Deterministic (simulated time only).

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "test_utilities/passivity_sweep.hpp"

namespace {

using teleop::control::PassivityMode;

// The transparency table of docs/link-emulation.md (issue 32.4).
int Transparency(const teleop::test::PassivityDelaySetup& setup, double wall_N_per_m, double press_force_N,
                 std::vector<int> delays) {
  if (delays.empty()) delays = {0, 10, 40, 100};
  std::printf(
      "K_p = %g N/m, K_d = %g N·s/m both sides, %g Hz, paper §4.1 masses; tracking: operator %g N sine at %g Hz, "
      "slave starts %g mm off, RMS of x_s - x_m over the last 0.5 s of %g s; wall: %g N/m on the slave, the "
      "operator ramps to %g N over %g s; alpha <= %g N·s/m\n",
      setup.kp_N_per_m, setup.kd_Ns_per_m, setup.rate_hz, setup.operator_amplitude_N, setup.operator_frequency_hz,
      setup.initial_offset_m * 1e3, setup.duration_s, wall_N_per_m, press_force_N, setup.duration_s * 2.0 / 3.0,
      setup.max_damping_Ns_per_m);
  std::printf("hand %g kg, %g N·s/m, %g N/m; link: + 0..%d samples of jitter, %g %% loss each way (seed %u)\n",
              setup.hand_mass_kg, setup.hand_damping_Ns_per_m, setup.hand_stiffness_N_per_m, setup.jitter_cycles,
              setup.loss * 100.0, setup.seed);
  std::printf("%6s %-16s %12s %13s %14s %10s %14s %14s %16s\n", "ms", "mode", "track_rms_mm", "perceived_N/m",
              "ideal_N/m", "drift_mm", "wall_ripple_mm", "min_energy_mJ", "wall_min_energy_mJ");
  for (const int d : delays) {
    for (const PassivityMode mode : {PassivityMode::kOff, PassivityMode::kObserver, PassivityMode::kEnergyExchange}) {
      const auto sine = teleop::test::RunPassivityDelay(setup, d, mode);
      const auto wall = teleop::test::RunWallPress(setup, d, mode, wall_N_per_m, press_force_N);
      std::printf("%6.1f %-16s %12.4f %13.1f %14.1f %10.3f %14.4f %14.4f %16.4f%s\n", 1e3 * d / setup.rate_hz,
                  teleop::control::ToString(mode), sine.late_tracking_rms_m * 1e3, wall.perceived_stiffness_N_per_m,
                  wall.ideal_stiffness_N_per_m, wall.hold_drift_m * 1e3, wall.hold_slave_std_m * 1e3,
                  sine.min_network_energy_J * 1e3, wall.min_network_energy_J * 1e3,
                  sine.diverged || wall.diverged ? " DIVERGED" : "");
    }
  }
  return 0;
}

int Run(int argc, char** argv) {
  teleop::test::PassivityDelaySetup setup;
  int first = 0;
  int last = 20;
  std::string csv;
  std::string png;
  CLI::App app{"passivity-delay-sweep: plain vs time-domain-passive law over a delayed link (lock-step, loopback)"};
  app.add_option("--rate-hz", setup.rate_hz, "loop rate")->check(CLI::Range(250.0, 8000.0));
  app.add_option("--kp", setup.kp_N_per_m, "K_p both sides, N/m")->check(CLI::Range(0.0, 1e5));
  app.add_option("--kd", setup.kd_Ns_per_m, "K_d both sides, N·s/m")->check(CLI::Range(0.0, 1e3));
  app.add_option("--max-damping", setup.max_damping_Ns_per_m, "passivity controller bound on α, N·s/m")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--max-force", setup.max_force_N, "law saturation, N (0 = none)")->check(CLI::Range(0.0, 1e4));
  app.add_option("--offset", setup.initial_offset_m, "slave start offset, m")->check(CLI::Range(-0.1, 0.1));
  app.add_option("--operator-amplitude", setup.operator_amplitude_N, "operator sine force amplitude, N")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--operator-frequency", setup.operator_frequency_hz, "operator sine frequency, Hz")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--duration", setup.duration_s, "simulated seconds per run")->check(CLI::Range(1.5, 600.0));
  app.add_option("--first", first, "first delay, samples per direction")->check(CLI::Range(0, 1000));
  app.add_option("--last", last, "last delay, samples per direction")->check(CLI::Range(0, 1000));
  double wall_N_per_m = 0.0;
  double press_force_N = 2.0;
  std::vector<int> delays;
  app.add_option(
         "--transparency", wall_N_per_m,
         "instead of the sweep: the transparency table at --delays, plain, observer and energy_exchange: tracking "
         "(the sine run), perceived stiffness at the master pressing the slave into a wall of this "
         "stiffness (N/m), lowest network energy")
      ->check(CLI::Range(1.0, 1e6));
  app.add_option("--press-force", press_force_N, "--transparency: the operator's final push, N")
      ->check(CLI::Range(0.01, 100.0));
  app.add_option("--delays", delays, "--transparency: one-way delays in samples, comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000));
  app.add_option("--hand-mass", setup.hand_mass_kg, "operator's hand mass on the master, kg (0: a force source)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--hand-damping", setup.hand_damping_Ns_per_m, "operator's hand damping, N·s/m")
      ->check(CLI::Range(0.0, 1e3));
  app.add_option("--hand-stiffness", setup.hand_stiffness_N_per_m, "operator's hand stiffness, N/m")
      ->check(CLI::Range(0.0, 1e5));
  app.add_option("--jitter", setup.jitter_cycles, "link jitter: each sample's delay + uniform 0..this, samples")
      ->check(CLI::Range(0, 1000));
  app.add_option("--loss", setup.loss, "link loss: each sample lost with this probability, each way")
      ->check(CLI::Range(0.0, 0.99));
  app.add_option("--seed", setup.seed, "seed of the jitter and loss draws");
  app.add_option("--csv", csv, "also write the table as CSV here");
  app.add_option("--png", png, "also plot late amplitude vs delay with gnuplot (needs --csv)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (wall_N_per_m > 0.0) return Transparency(setup, wall_N_per_m, press_force_N, delays);
  if (last < first) {
    std::cerr << "passivity-delay-sweep: --last must be >= --first\n";
    return 2;
  }
  if (!png.empty() && csv.empty()) {
    std::cerr << "passivity-delay-sweep: --png needs --csv\n";
    return 2;
  }
  const std::vector<PassivityMode> modes = {PassivityMode::kOff, PassivityMode::kObserver,
                                            PassivityMode::kEnergyExchange};
  const auto results = teleop::test::SweepPassivityDelay(setup, first, last, modes);

  std::printf(
      "K_p = %g N/m, K_d = %g N·s/m both sides, %g Hz, paper §4.1 masses, slave starts %g mm off, "
      "operator %g N sine at %g Hz, %g s per run, alpha <= %g N·s/m\n",
      setup.kp_N_per_m, setup.kd_Ns_per_m, setup.rate_hz, setup.initial_offset_m * 1e3, setup.operator_amplitude_N,
      setup.operator_frequency_hz, setup.duration_s, setup.max_damping_Ns_per_m);
  std::printf("%5s %6s %-16s %11s %11s %9s %11s %11s %14s %11s %9s %s\n", "delay", "ms", "mode", "early_pp_mm",
              "late_pp_mm", "growth", "track_rms_mm", "master_pp_mm", "min_network_mJ", "dissip_mJ", "pc_cycles",
              "verdict");
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    if (!out) {
      std::cerr << "passivity-delay-sweep: cannot write " << csv << "\n";
      return 1;
    }
    out << "delay_samples,delay_ms,mode,early_pp_m,late_pp_m,growth,late_tracking_rms_m,late_master_pp_m,"
           "min_network_energy_J,final_network_energy_J,"
           "dissipated_J,pc_cycles,diverged,unstable\n";
  }
  for (const auto& r : results) {
    const double ms = 1e3 * r.delay_cycles / setup.rate_hz;
    std::printf("%5d %6.1f %-16s %11.4f %11.4f %9.3f %11.4f %11.3f %14.4f %11.4f %9llu %s\n", r.delay_cycles, ms,
                teleop::control::ToString(r.mode), r.early_amplitude_m * 1e3, r.late_amplitude_m * 1e3, r.growth,
                r.late_tracking_rms_m * 1e3, r.late_master_pp_m * 1e3, r.min_network_energy_J * 1e3,
                r.dissipated_J * 1e3, static_cast<unsigned long long>(r.acting_cycles),
                r.diverged ? "DIVERGED" : (r.unstable() ? "UNSTABLE" : "bounded"));
    if (out) {
      out << r.delay_cycles << ',' << ms << ',' << teleop::control::ToString(r.mode) << ',' << r.early_amplitude_m
          << ',' << r.late_amplitude_m << ',' << r.growth << ',' << r.late_tracking_rms_m << ',' << r.late_master_pp_m
          << ',' << r.min_network_energy_J << ',' << r.final_network_energy_J << ',' << r.dissipated_J << ','
          << r.acting_cycles << ',' << (r.diverged ? 1 : 0) << ',' << (r.unstable() ? 1 : 0) << '\n';
    }
  }
  for (const PassivityMode mode : modes) {
    const int d = teleop::test::FirstUnstableDelay(results, mode);
    if (d < 0) {
      std::printf("%-16s bounded at every delay in %d..%d samples\n", teleop::control::ToString(mode), first, last);
    } else {
      std::printf("%-16s first unstable at %d samples (%.1f ms) per direction\n", teleop::control::ToString(mode), d,
                  1e3 * d / setup.rate_hz);
    }
  }
  if (!png.empty()) {
    out.close();
    const std::string script = png + ".gp";
    {
      std::ofstream gp(script);
      gp << "set terminal pngcairo size 900,500 noenhanced\nset output '" << png << "'\n"
         << "set datafile separator ','\nset logscale y\nset yrange [0.1:3000]\n"
         << "set xlabel 'one-way delay (samples)'\n"
         << "set ylabel 'late p-p tracking error (mm; diverged = 1000)'\nset key top left\n"
         << "plot for [m in 'off observer energy_exchange'] '" << csv
         << "' using 1:(strcol(3) eq m ? ($13 > 0 ? 1000 : 1e3*$5) : 1/0) with linespoints pointsize 1.5 title m\n";
    }
    if (std::system(("gnuplot '" + script + "' 2>&1").c_str()) != 0) {
      std::cerr << "passivity-delay-sweep: gnuplot failed or is missing (script " << script << ")\n";
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "passivity-delay-sweep: " << e.what() << "\n";
    return 1;
  }
}
