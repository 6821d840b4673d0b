// The Colgate, Wannasuphoprasit & Peshkin cobot scenarios (docs/cobot.md): the simulated unicycle cobot with a
// scripted operator, one subcommand per figure. Each writes <output>.csv (+ .png via gnuplot) and prints metrics.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "scenarios.hpp"
#include "teleop/device/cobot/cobot_backend.hpp"
#include "teleop/device/cobot/scripted_operator.hpp"
#include "teleop/device/cobot/tracking_stability.hpp"
#include "teleop/device/cobot/unicycle_cobot.hpp"
#include "teleop/error.hpp"

namespace teleop::scenario {

namespace {

using device::cobot::Constraint;
using device::cobot::UnicycleCobot;
using device::cobot::UnicycleCobotConfig;
using device::cobot::UnicyclePlantState;
using device::cobot::Vec2;
using device::cobot::WallMode;

constexpr double kPeriod_s = 0.001;  // the prototype's 1 kHz
constexpr double kDegToRad = std::numbers::pi / 180.0;

struct CommonOptions {
  std::string output;
  bool json = false;
  bool no_plot = false;
};

void AddCommon(CLI::App* sub, CommonOptions& o, const std::string& default_output) {
  o.output = default_output;
  sub->add_option("--output", o.output, "Output prefix: <output>.csv and <output>.png")->capture_default_str();
  sub->add_flag("--json", o.json, "Print one JSON object with the metrics");
  sub->add_flag("--no-plot", o.no_plot, "Write the CSV only (no gnuplot)");
}

void RunGnuplot(const std::string& script_path, const std::string& script) {
  {
    std::ofstream gp(script_path);
    if (!gp) throw Error(script_path + ": cannot write the gnuplot script");
    gp << script;
  }
  const std::string command = "gnuplot '" + script_path + "' 2>&1";
  if (std::system(command.c_str()) != 0) {
    std::cerr << "teleop-scenario: gnuplot failed or is missing; the data are in the CSV (script " << script_path
              << ")\n";
  }
}

std::ofstream OpenCsv(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot write the CSV");
  out << std::setprecision(9);
  return out;
}

/// One run's trajectory: the CSV the plots read.
struct Trajectory {
  std::ofstream csv;
  int every = 1;
  int count = 0;
  explicit Trajectory(const std::string& path, int every_samples) : csv(OpenCsv(path)), every(every_samples) {
    csv << "t_s,x_m,y_m,heading_rad,speed_m_per_s,steering_rate_rad_per_s,force_x_N,force_y_N,lateral_force_N,"
           "lateral_acceleration_m_per_s2,steering_torque_Nm,mode,penetration_m,theta_rad,overlay_radius_m\n";
  }
  void Add(double t, const device::cobot::CobotSample& s) {
    if (count++ % every != 0) return;
    csv << t << ',' << s.position_m.x() << ',' << s.position_m.y() << ',' << s.heading_rad << ',' << s.speed_m_per_s
        << ',' << s.steering_rate_rad_per_s << ',' << s.handle_force_N.x() << ',' << s.handle_force_N.y() << ','
        << s.lateral_force_N << ',' << s.lateral_acceleration_m_per_s2 << ',' << s.steering_torque_Nm << ','
        << static_cast<int>(s.control.mode) << ',' << s.control.penetration_m << ',' << s.control.theta_rad << ','
        << s.control.overlay_radius_m << '\n';
  }
};

/// Writes the constraint curve as x,y rows for the plot.
void WriteConstraintCsv(const std::string& path, const Constraint& c, double x_min, double x_max) {
  std::ofstream out = OpenCsv(path);
  out << "x_m,y_m\n";
  if (c.kind() == Constraint::Kind::kCircle) {
    for (int i = 0; i <= 360; ++i) {
      const double a = i * kDegToRad;
      out << c.anchor_m().x() + c.radius_m() * std::cos(a) << ',' << c.anchor_m().y() + c.radius_m() * std::sin(a)
          << '\n';
    }
  } else {
    out << x_min << ',' << c.anchor_m().y() << '\n' << x_max << ',' << c.anchor_m().y() << '\n';
  }
}

/// Trajectory plot in mm with operator force arrows (like Figs 4, 7, 9).
std::string TrajectoryPlot(const std::string& png, const std::string& title,
                           const std::vector<std::pair<std::string, std::string>>& runs, const std::string& wall_csv,
                           double arrow_mm_per_N, int arrow_every, bool equal_axes) {
  std::ostringstream gp;
  gp << "set terminal png size 900,700\nset output '" << png << "'\nset datafile separator ','\n"
     << "set title '" << title
     << "' noenhanced\nset xlabel 'x (mm)'\nset ylabel 'y (mm)'\nset grid\nset key outside bottom\nset clip two\n";
  if (equal_axes) gp << "set size ratio -1\n";
  gp << "plot ";
  bool first = true;
  if (!wall_csv.empty()) {
    gp << "'" << wall_csv << "' skip 1 using ($1*1000):($2*1000) with lines lw 3 lc rgb 'black' title 'constraint'";
    first = false;
  }
  int colour = 1;
  for (const auto& [csv, label] : runs) {
    if (!first) gp << ", \\\n     ";
    first = false;
    gp << "'" << csv << "' skip 1 using ($2*1000):($3*1000) with lines lw 2 lc " << colour << " title '" << label
       << "', '" << csv << "' skip 1 every " << arrow_every << " using ($2*1000):($3*1000):($7*" << arrow_mm_per_N
       << "):($8*" << arrow_mm_per_N << ") with vectors head filled lc " << colour << " title 'operator force ("
       << std::setprecision(3) << arrow_mm_per_N << " mm/N" << (equal_axes ? "" : " per axis; axes not to scale")
       << ")'";
    ++colour;
  }
  gp << "\n";
  return gp.str();
}

// ---------------------------------------------------------------- cobot-caster

struct CasterOptions {
  CommonOptions common;
  double speed_m_per_s = 0.2;
  double lateral_acceleration_m_per_s2 = 0.05;
  double duration_s = 8.0;
};

/// Arrows about a quarter of the turning radius for the force that holds the speed against rolling resistance.
double CasterArrowScale_mm_per_N(const CasterOptions& o, const UnicycleCobotConfig& config) {
  const double radius_mm = 1e3 * o.speed_m_per_s * o.speed_m_per_s / o.lateral_acceleration_m_per_s2;
  const double rolling_N = config.plant.rolling_damping_Ns_per_m * o.speed_m_per_s;
  return radius_mm / (4.0 * std::max(1.0, rolling_N));
}

int RunCaster(const CasterOptions& o) {
  if (!(o.speed_m_per_s > 0.0) || !(o.lateral_acceleration_m_per_s2 > 0.0) || !(o.duration_s > 2.0)) {
    throw Error("cobot-caster: --speed-m-s and --lateral-accel-m-s2 must be > 0 and --duration-s > 2");
  }
  UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  UnicyclePlantState initial;
  initial.speed_m_per_s = o.speed_m_per_s;
  UnicycleCobot cobot(config, Constraint::Line({0.0, 1e3}, {1.0, 0.0}, true), initial);
  cobot.controller().SetWallActive(false);
  device::cobot::TurningOperatorConfig op_config;
  op_config.speed_m_per_s = o.speed_m_per_s;
  op_config.lateral_acceleration_m_per_s2 = o.lateral_acceleration_m_per_s2;
  device::cobot::TurningOperator op(op_config);

  Trajectory traj(o.common.output + ".csv", 10);
  const int steps = static_cast<int>(o.duration_s / kPeriod_s);
  const int settle = steps / 2;  // average over the second half (steady turning)
  double sum_force = 0.0;
  double sum_accel = 0.0;
  double sum_speed = 0.0;
  int n = 0;
  for (int k = 0; k < steps; ++k) {
    const Vec2 force = op.Step(cobot.state(), kPeriod_s);
    const auto s = cobot.Step(force, kPeriod_s);
    traj.Add((k + 1) * kPeriod_s, s);
    if (k >= settle) {
      sum_force += s.lateral_force_N;
      sum_accel += s.lateral_acceleration_m_per_s2;
      sum_speed += s.speed_m_per_s;
      ++n;
    }
  }
  traj.csv.close();
  const double lateral_force = sum_force / n;
  const double lateral_accel = sum_accel / n;
  const double mean_speed = sum_speed / n;
  const double apparent = lateral_force / lateral_accel;
  const double virtual_mass = 1.0 / config.controller.caster.k1_per_kg;
  const double floor = config.controller.caster.speed_floor_m_per_s;
  const double predicted = virtual_mass * std::max(1.0, floor / std::abs(mean_speed));
  if (!o.common.no_plot) {
    std::ostringstream title;
    title << "cobot-caster " << o.speed_m_per_s << " m/s, " << o.lateral_acceleration_m_per_s2
          << " m/s^2: apparent lateral mass " << std::setprecision(3) << apparent << " kg";
    const std::string png = o.common.output + ".png";
    RunGnuplot(o.common.output + ".gp",
               TrajectoryPlot(png, title.str(), {{o.common.output + ".csv", "cart (virtual caster)"}}, "",
                              CasterArrowScale_mm_per_N(o, config), 100, true));
  }
  if (o.common.json) {
    std::cout << std::setprecision(6) << "{\"scenario\":\"cobot-caster\",\"speed_m_per_s\":" << mean_speed
              << ",\"lateral_acceleration_m_per_s2\":" << lateral_accel << ",\"lateral_force_N\":" << lateral_force
              << ",\"apparent_mass_kg\":" << apparent << ",\"virtual_mass_kg\":" << virtual_mass
              << ",\"speed_floor_m_per_s\":" << floor << ",\"predicted_apparent_mass_kg\":" << predicted << "}\n";
  } else {
    std::cout << "cobot-caster: speed " << mean_speed << " m/s, lateral acceleration " << lateral_accel
              << " m/s^2, lateral force " << lateral_force << " N\n  apparent lateral mass " << apparent
              << " kg (virtual mass 1/K1 = " << virtual_mass << " kg; eq 2 predicts " << predicted
              << " kg with epsilon = " << floor << " m/s)\n  " << o.common.output << ".csv\n";
  }
  return 0;
}

// ---------------------------------------------------------------- cobot-track and cobot-wall

struct StrikeSetup {
  UnicycleCobotConfig config;
  Constraint wall;
  UnicyclePlantState initial;
  device::cobot::PushingOperatorConfig op;
  double duration_s = 4.0;
};

struct StrikeResult {
  double max_penetration_m = 0.0;
  double steady_error_m = 0.0;  ///< Mean p over the last quarter.
  double steady_rms_m = 0.0;
  int engages = 0;
  int releases = 0;
  double first_contact_s = -1.0;
};

/// A strike's per-step bookkeeping: peak penetration, first contact, and the mean and rms of p over the last quarter
/// of `steps` steps.
class StrikeStats {
 public:
  explicit StrikeStats(int steps) : tail_(steps - steps / 4) {}
  void Add(int k, double penetration_m, WallMode mode, StrikeResult& r) {
    r.max_penetration_m = std::max(r.max_penetration_m, penetration_m);
    if (r.first_contact_s < 0.0 && mode != WallMode::kCaster) r.first_contact_s = (k + 1) * kPeriod_s;
    if (k >= tail_) {
      sum_ += penetration_m;
      sum_sq_ += penetration_m * penetration_m;
      ++n_;
    }
  }
  void Finish(StrikeResult& r) const {
    r.steady_error_m = sum_ / n_;
    r.steady_rms_m = std::sqrt(sum_sq_ / n_);
  }

 private:
  int tail_;
  double sum_ = 0.0;
  double sum_sq_ = 0.0;
  int n_ = 0;
};

StrikeResult RunStrike(const StrikeSetup& setup, const std::string& csv_path) {
  UnicycleCobot cobot(setup.config, setup.wall, setup.initial);
  device::cobot::PushingOperator op(setup.op, setup.wall);
  Trajectory traj(csv_path, 5);
  StrikeResult r;
  const int steps = static_cast<int>(setup.duration_s / kPeriod_s);
  StrikeStats stats(steps);
  for (int k = 0; k < steps; ++k) {
    const Vec2 force = op.Step(cobot.state(), kPeriod_s);
    const auto s = cobot.Step(force, kPeriod_s);
    traj.Add((k + 1) * kPeriod_s, s);
    const double p = setup.wall.Evaluate(s.position_m).penetration_m;
    stats.Add(k, p, s.control.mode, r);
  }
  stats.Finish(r);
  r.engages = cobot.controller().engage_count();
  r.releases = cobot.controller().release_count();
  return r;
}

struct TrackOptions {
  CommonOptions common;
  std::string path = "line";
  bool integral = false;
  bool compensate = false;
  double speed_m_per_s = 0.2;
  double push_angle_deg = 30.0;
  double lookahead_m = 0.05;
};

int RunTrack(const TrackOptions& o) {
  StrikeSetup s;
  s.config = UnicycleCobotConfig::Prototype();
  s.config.controller.overlay_enabled = false;  // Figs 4 and 7: plain switching, an initial penetration
  s.config.controller.tracker.lookahead_m = o.lookahead_m;
  if (o.integral) s.config.controller.tracker.integral_gain_per_m3 = 0.5 / std::pow(o.lookahead_m, 3);
  if (o.compensate) {
    s.config.controller.tracker.friction_compensation_Nms_per_rad = s.config.plant.steering_damping_Nms_per_rad;
  }
  const double angle = o.push_angle_deg * kDegToRad;
  s.op.speed_m_per_s = o.speed_m_per_s;
  s.op.push_angle_rad = angle;
  s.initial.speed_m_per_s = o.speed_m_per_s;
  double x_min = -0.05;
  double x_max = 1.0;
  if (o.path == "line") {
    s.wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, /*forbidden_left=*/true);  // wall y > 0
    s.initial.position_m = {0.0, -0.05};
    s.initial.heading_rad = angle;
    s.duration_s = 5.0;
  } else if (o.path == "circle") {
    s.wall = Constraint::Circle({0.0, 0.0}, 0.3, /*forbidden_outside=*/true);  // keep inside the 0.3 m circle
    s.initial.position_m = {0.0, -0.25};
    s.initial.heading_rad = -angle;  // at the bottom the tangent is +x and the wall is below: push down-right
    s.duration_s = 8.0;
  } else {
    throw Error("cobot-track: --path must be line or circle (got '" + o.path + "')");
  }
  const std::string csv = o.common.output + ".csv";
  const StrikeResult r = RunStrike(s, csv);
  if (!o.common.no_plot) {
    const std::string wall_csv = o.common.output + "_constraint.csv";
    WriteConstraintCsv(wall_csv, s.wall, x_min, x_max);
    std::ostringstream title;
    title << "cobot-track --path " << o.path << (o.integral ? " --integral" : "") << ": initial penetration "
          << std::setprecision(3) << r.max_penetration_m * 1e3 << " mm, steady-state error " << r.steady_error_m * 1e3
          << " mm";
    RunGnuplot(o.common.output + ".gp", TrajectoryPlot(o.common.output + ".png", title.str(), {{csv, "cart"}}, wall_csv,
                                                       4.0, 60, o.path == "circle"));
  }
  if (o.common.json) {
    std::cout << std::setprecision(6) << "{\"scenario\":\"cobot-track\",\"path\":\"" << o.path
              << "\",\"integral\":" << (o.integral ? "true" : "false")
              << ",\"initial_penetration_mm\":" << r.max_penetration_m * 1e3
              << ",\"steady_state_error_mm\":" << r.steady_error_m * 1e3
              << ",\"steady_state_rms_mm\":" << r.steady_rms_m * 1e3 << ",\"first_contact_s\":" << r.first_contact_s
              << ",\"releases\":" << r.releases << "}\n";
  } else {
    std::cout << "cobot-track --path " << o.path << ": initial penetration " << r.max_penetration_m * 1e3
              << " mm, steady-state error " << r.steady_error_m * 1e3 << " mm (rms " << r.steady_rms_m * 1e3
              << " mm), contact at " << r.first_contact_s << " s\n  " << csv << "\n";
  }
  return 0;
}

struct WallOptions {
  CommonOptions common;
  std::string overlay = "on";
  std::string vehicle = "unicycle";
  double speed_m_per_s = 0.3;
  double approach_angle_deg = 60.0;
  double overlay_min_radius_m = 0.1;
};

StrikeSetup WallSetup(const WallOptions& o, bool overlay) {
  StrikeSetup s;
  s.config = UnicycleCobotConfig::Prototype();
  s.config.controller.overlay_enabled = overlay;
  s.config.controller.overlay_min_radius_m = o.overlay_min_radius_m;
  const double angle = o.approach_angle_deg * kDegToRad;
  s.op.speed_m_per_s = o.speed_m_per_s;
  s.op.push_angle_rad = angle;
  s.wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  s.initial.position_m = {0.0, -0.15};
  s.initial.heading_rad = angle;
  s.initial.speed_m_per_s = o.speed_m_per_s;
  s.duration_s = 2.0;
  return s;
}

/// The bicycle cobot (its plate's reference point, midway between the wheels) strikes the same wall y > 0 as a
/// fixture plane through the `cobot` backend: the plate starts 150 mm below it with its wheels along the approach
/// and the scripted operator pushes towards it at the approach angle.
StrikeResult RunBicycleStrike(const WallOptions& o, bool overlay, const std::string& csv_path) {
  device::cobot::CobotBackendConfig c;
  c.kind = device::cobot::CobotBackendConfig::Kind::kBicycle;
  c.unicycle.controller.overlay_enabled = overlay;
  c.unicycle.controller.overlay_min_radius_m = o.overlay_min_radius_m;
  c.initial.position_m = {0.0, -0.15};
  c.initial.heading_rad = o.approach_angle_deg * kDegToRad;  // the plate's θ: wheels along the approach
  c.op.enabled = true;
  c.op.speed_m_per_s = o.speed_m_per_s;
  c.op.direction_deg = o.approach_angle_deg;
  device::cobot::BicycleCobotDevice bicycle(c);
  device::Command plane = device::Command::Force(DofVector::Zero(3));
  plane.constraint_count = 1;
  plane.constraints[0].normal = DofVector::Zero(3);
  plane.constraints[0].normal << 0.0, 1.0, 0.0;
  plane.constraints[0].offset_m = 0.0;
  Trajectory traj(csv_path, 5);
  StrikeResult r;
  const int steps = static_cast<int>(2.0 / kPeriod_s);
  StrikeStats stats(steps);
  device::Reading reading;
  for (int k = 0; k < steps; ++k) {
    bicycle.Read(reading);
    bicycle.Write(plane);
    bicycle.Update(kPeriod_s);
    const auto& st = bicycle.state();
    device::cobot::CobotSample s;
    s.position_m = st.pose.position_m;
    s.heading_rad = bicycle.virtual_heading_rad();
    s.speed_m_per_s = Vec2(st.twist(0), st.twist(1)).norm();
    s.handle_force_N = bicycle.operator_force_N();
    s.control = bicycle.last_control();
    traj.Add((k + 1) * kPeriod_s, s);
    const double p = s.position_m.y();
    stats.Add(k, p, s.control.mode, r);
  }
  stats.Finish(r);
  r.engages = bicycle.controller().engage_count();
  r.releases = bicycle.controller().release_count();
  return r;
}

int RunWall(const WallOptions& o) {
  if (o.overlay != "on" && o.overlay != "off") {
    throw Error("cobot-wall: --overlay must be on or off (got '" + o.overlay + "')");
  }
  if (!(o.approach_angle_deg > 0.0 && o.approach_angle_deg < 90.0)) {
    throw Error("cobot-wall: --approach-angle-deg must be in (0, 90)");
  }
  if (o.vehicle != "unicycle" && o.vehicle != "bicycle") {
    throw Error("cobot-wall: --vehicle must be unicycle or bicycle (got '" + o.vehicle + "')");
  }
  const bool bicycle = o.vehicle == "bicycle";
  const auto strike = [&](bool with_overlay, const std::string& path) {
    return bicycle ? RunBicycleStrike(o, with_overlay, path) : RunStrike(WallSetup(o, with_overlay), path);
  };
  const bool overlay = o.overlay == "on";
  const std::string csv = o.common.output + ".csv";
  const StrikeResult r = strike(overlay, csv);
  if (!o.common.no_plot) {
    // Fig. 9 shows both strikes: run the other one too, for the plot only.
    const std::string other_csv = o.common.output + "_overlay_" + (overlay ? "off" : "on") + ".csv";
    const StrikeResult other = strike(!overlay, other_csv);
    const std::string wall_csv = o.common.output + "_constraint.csv";
    WriteConstraintCsv(wall_csv, Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true), -0.02, 0.35);
    std::ostringstream title;
    title << "cobot-wall (" << o.vehicle << "): max penetration " << std::setprecision(3) << r.max_penetration_m * 1e3
          << " mm with overlay " << o.overlay << ", " << other.max_penetration_m * 1e3 << " mm with it "
          << (overlay ? "off" : "on");
    std::string script = TrajectoryPlot(
        o.common.output + ".png", title.str(),
        {{csv, std::string("overlay ") + o.overlay}, {other_csv, std::string("overlay ") + (overlay ? "off" : "on")}},
        wall_csv, 2.0, 30, false);
    script = "set xrange [0:250]\nset yrange [-160:30]\n" + script;
    RunGnuplot(o.common.output + ".gp", script);
  }
  if (o.common.json) {
    std::cout << std::setprecision(6) << "{\"scenario\":\"cobot-wall\",\"vehicle\":\"" << o.vehicle
              << "\",\"overlay\":\"" << o.overlay << "\",\"max_penetration_mm\":" << r.max_penetration_m * 1e3
              << ",\"steady_state_error_mm\":" << r.steady_error_m * 1e3 << ",\"engages\":" << r.engages
              << ",\"releases\":" << r.releases << "}\n";
  } else {
    std::cout << "cobot-wall --vehicle " << o.vehicle << " --overlay " << o.overlay << ": max penetration "
              << r.max_penetration_m * 1e3 << " mm (approach " << o.approach_angle_deg << " deg at " << o.speed_m_per_s
              << " m/s)\n  " << csv << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- cobot-stability

struct StabilityOptions {
  CommonOptions common;
  std::vector<double> tau_s{0.05, 0.1, 0.2};
  std::vector<double> lookahead_m{0.01, 0.02, 0.05};
  std::vector<double> ratios{0.25, 0.5, 0.75, 0.9, 1.1, 1.25, 1.5, 2.0};
  double rate_filter_hz = 300.0;  ///< Cut-off of the ω estimate's low-pass (it sits inside the steering loop).
  double step_s = kPeriod_s;      ///< Control and integration step.
};

/// Bilateral line tracking from a 2 mm offset at constant speed. Returns the late/early amplitude ratio of p
/// (max |p| over the last quarter of the run over max |p| over the second quarter), or 0 when p has settled below
/// 5 % of the offset (converged to the sensor noise); at least 1 when the late amplitude is still above the offset
/// (a limit cycle is not convergence). Converging: the returned value is < 1.
constexpr double kInitialOffset_m = 0.002;
constexpr double kConvergedRatio = 1.0;

double TrackingGrowth(const StabilityOptions& o, double speed_m_per_s, double tau_s, double lookahead_m) {
  UnicycleCobotConfig c = UnicycleCobotConfig::Prototype();
  c.plant.steering_damping_Nms_per_rad = 0.0;   // the analysis' first-order steering loop exactly
  c.plant.cornering_stiffness_N_per_rad = 0.0;  // and ideal rolling
  c.plant.max_steering_torque_Nm = 50.0;
  const double k2 = device::cobot::SteeringGainFor(c.plant, tau_s);
  c.controller.caster.k2_Nms_per_rad = k2;
  c.controller.caster.friction_compensation_Nms_per_rad = 0.0;
  c.controller.tracker.k2_Nms_per_rad = k2;
  c.controller.tracker.lookahead_m = lookahead_m;
  c.controller.tracker.max_curvature_per_m = 1e4;
  c.controller.overlay_enabled = false;
  c.controller.release_distance_m = 10.0;  // bilateral, as analysed
  c.controller.release_force_N = 1e6;
  c.steering_rate_filter.cutoff_hz = o.rate_filter_hz;
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  UnicyclePlantState initial;
  initial.position_m = {0.0, kInitialOffset_m};
  initial.speed_m_per_s = speed_m_per_s;
  UnicycleCobot cobot(c, wall, initial);
  device::cobot::PushingOperatorConfig op_config;
  op_config.speed_m_per_s = speed_m_per_s;
  op_config.push_angle_rad = 0.0;
  op_config.max_force_N = 500.0;
  device::cobot::PushingOperator op(op_config, wall);
  const double arc_m = 60.0 * lookahead_m;
  const int steps = static_cast<int>(std::clamp(arc_m / speed_m_per_s, 1.0, 30.0) / o.step_s);
  double early = 0.0;
  double late = 0.0;
  for (int k = 0; k < steps; ++k) {
    const auto s = cobot.Step(op.Step(cobot.state(), o.step_s), o.step_s);
    const double p = std::abs(wall.Evaluate(s.position_m).penetration_m);
    if (!std::isfinite(p) || p > 0.2) return 1e3;  // diverged
    if (k >= steps / 4 && k < steps / 2) early = std::max(early, p);
    if (k >= 3 * steps / 4) late = std::max(late, p);
  }
  if (late < 0.05 * kInitialOffset_m) return 0.0;
  const double ratio = late / std::max(early, 1e-12);
  return late >= kInitialOffset_m ? std::max(ratio, 1.0) : ratio;
}

int RunStability(const StabilityOptions& o) {
  if (!(o.rate_filter_hz > 0.0) || !(o.step_s > 0.0 && o.step_s <= 0.01)) {
    throw Error("cobot-stability: --rate-filter-hz must be > 0 and --step-s in (0, 0.01]");
  }
  const std::string csv_path = o.common.output + ".csv";
  const std::string boundary_path = o.common.output + "_boundary.csv";
  std::ofstream csv = OpenCsv(csv_path);
  std::ofstream boundary = OpenCsv(boundary_path);
  csv << "tau_s,lookahead_m,speed_m_per_s,u_tau_m,u_tau_over_L,growth_ratio,stable_sim,stable_eq10\n";
  boundary << "tau_s,lookahead_m,u_max_eq10_m_per_s,u_max_sim_m_per_s,u_tau_sim_m\n";
  std::ostringstream json;
  json << std::setprecision(6) << "{\"scenario\":\"cobot-stability\",\"pairs\":[";
  bool first = true;
  for (const double tau : o.tau_s) {
    for (const double lookahead : o.lookahead_m) {
      device::cobot::ConstraintTrackerConfig tracker;
      tracker.lookahead_m = lookahead;
      const double u_formula = device::cobot::MaxStableSpeed_m_per_s(tracker, tau, 0.0);
      for (const double ratio : o.ratios) {
        const double u = ratio * u_formula;
        const double growth = TrackingGrowth(o, u, tau, lookahead);
        csv << tau << ',' << lookahead << ',' << u << ',' << u * tau << ',' << ratio << ',' << growth << ','
            << (growth < kConvergedRatio ? 1 : 0) << ',' << (ratio < 1.0 ? 1 : 0) << '\n';
      }
      // The simulated boundary: bisection on the speed between stable and unstable.
      double lo = 0.25 * u_formula;
      double hi = 3.0 * u_formula;
      if (TrackingGrowth(o, hi, tau, lookahead) < kConvergedRatio) {
        lo = hi;  // stable up to the top of the range
      } else {
        for (int i = 0; i < 12; ++i) {
          const double mid = 0.5 * (lo + hi);
          (TrackingGrowth(o, mid, tau, lookahead) < kConvergedRatio ? lo : hi) = mid;
        }
      }
      const double u_sim = 0.5 * (lo + hi);
      boundary << tau << ',' << lookahead << ',' << u_formula << ',' << u_sim << ',' << u_sim * tau << '\n';
      json << (first ? "" : ",") << "{\"tau_s\":" << tau << ",\"lookahead_m\":" << lookahead
           << ",\"u_max_eq10_m_per_s\":" << u_formula << ",\"u_max_sim_m_per_s\":" << u_sim << "}";
      first = false;
      if (!o.common.json) {
        std::cout << "tau " << tau << " s, L " << lookahead << " m: eq 10 (u tau < L) u_max = " << u_formula
                  << " m/s, simulation u_max = " << u_sim << " m/s (ratio " << u_sim / u_formula << ")\n";
      }
    }
  }
  csv.close();
  boundary.close();
  json << "]}";
  if (!o.common.no_plot) {
    std::ostringstream gp;
    gp << "set terminal png size 900,700\nset output '" << o.common.output << ".png'\nset datafile separator ','\n"
       << "set title 'cobot-stability: line tracking, eq 8 gains; eq 11 boundary u*tau = L' noenhanced\n"
       << "set xlabel 'u*tau (mm)'\nset ylabel 'lookahead L (mm)'\nset grid\nset key top left\nset logscale xy\n"
       << "plot '" << csv_path << "' skip 1 using ($7==1 ? $4*1000 : 1/0):($2*1000) with points pt 7 ps 1.5 lc rgb "
       << "'forest-green' title 'simulation: converges', '" << csv_path
       << "' skip 1 using ($7==0 ? $4*1000 : 1/0):($2*1000) with points pt 5 ps 1.5 lc rgb 'red' title "
       << "'simulation: oscillates/diverges', '" << boundary_path
       << "' skip 1 using ($5*1000):($2*1000) with points pt 3 ps 3 lw 2 lc rgb 'black' title "
       << "'simulated boundary (bisection)', x with lines lw 2 lc rgb 'blue' title 'eq 11: u tau = L'\n";
    RunGnuplot(o.common.output + ".gp", gp.str());
  }
  if (o.common.json) {
    std::cout << json.str() << "\n";
  } else {
    std::cout << "  " << csv_path << ", " << boundary_path << "\n";
  }
  return 0;
}

}  // namespace

void AddCobotScenarios(CLI::App& app) {
  {
    auto o = std::make_shared<CasterOptions>();
    CLI::App* sub = app.add_subcommand("cobot-caster", "Virtual caster (eq 2): operator force vs speed, apparent mass");
    AddCommon(sub, o->common, "cobot_caster");
    sub->add_option("--speed-m-s", o->speed_m_per_s, "Cart speed the operator holds (m/s)")->capture_default_str();
    sub->add_option("--lateral-accel-m-s2", o->lateral_acceleration_m_per_s2,
                    "Lateral acceleration the operator turns at (m/s^2)")
        ->capture_default_str();
    sub->add_option("--duration-s", o->duration_s, "Run length (s); metrics over the second half")
        ->capture_default_str();
    sub->callback([o] { RunCaster(*o); });
  }
  {
    auto o = std::make_shared<TrackOptions>();
    CLI::App* sub = app.add_subcommand("cobot-track", "Constraint tracking (eqs 7-8, Figs 4 and 7)");
    AddCommon(sub, o->common, "cobot_track");
    sub->add_option("--path", o->path, "line or circle")->capture_default_str();
    sub->add_flag("--integral", o->integral, "Integral action on the penetration (k_i = 0.5/L^3)");
    sub->add_flag("--compensate", o->compensate, "Feed-forward the steering friction (the paper's nominal boost)");
    sub->add_option("--speed-m-s", o->speed_m_per_s, "Cart speed (m/s)")->capture_default_str();
    sub->add_option("--push-angle-deg", o->push_angle_deg, "Operator push direction into the wall (deg)")
        ->capture_default_str();
    sub->add_option("--lookahead-m", o->lookahead_m, "Lookahead L (m)")->capture_default_str();
    sub->callback([o] { RunTrack(*o); });
  }
  {
    auto o = std::make_shared<WallOptions>();
    CLI::App* sub = app.add_subcommand("cobot-wall", "Virtual wall strike with and without overlay (Fig. 9)");
    AddCommon(sub, o->common, "cobot_wall");
    sub->add_option("--overlay", o->overlay, "on or off")->capture_default_str();
    sub->add_option("--vehicle", o->vehicle, "unicycle, or bicycle (the wall on the plate's reference point)")
        ->capture_default_str();
    sub->add_option("--speed-m-s", o->speed_m_per_s, "Cart speed (m/s)")->capture_default_str();
    sub->add_option("--approach-angle-deg", o->approach_angle_deg, "Approach angle to the wall (deg)")
        ->capture_default_str();
    sub->add_option("--overlay-min-radius-m", o->overlay_min_radius_m, "Overlay activation radius (m)")
        ->capture_default_str();
    sub->callback([o] { RunWall(*o); });
  }
  {
    auto o = std::make_shared<StabilityOptions>();
    CLI::App* sub = app.add_subcommand("cobot-stability", "Sweep u, tau, L: eq 10/11 boundary in simulation");
    AddCommon(sub, o->common, "cobot_stability");
    sub->add_option("--tau-s", o->tau_s, "Steering time constants (s)")->delimiter(',');
    sub->add_option("--lookahead-m", o->lookahead_m, "Lookahead distances (m)")->delimiter(',');
    sub->add_option("--ratios", o->ratios, "Speeds as multiples of L/tau")->delimiter(',');
    sub->add_option("--rate-filter-hz", o->rate_filter_hz, "Cut-off of the steering-rate estimate's low-pass (Hz)")
        ->capture_default_str();
    sub->add_option("--step-s", o->step_s, "Control and integration step (s)")->capture_default_str();
    sub->callback([o] { RunStability(*o); });
  }
}

}  // namespace teleop::scenario
