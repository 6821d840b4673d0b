// The Colgate, Wannasuphoprasit & Peshkin cobot scenarios (docs/cobot.md): the simulated unicycle cobot with a
// scripted operator, one subcommand per figure. Each writes <output>.csv (+ .png via gnuplot) and prints metrics.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "device/cobot/bicycle_caster.hpp"
#include "device/cobot/bicycle_plant.hpp"
#include "device/cobot/bicycle_sensing.hpp"
#include "device/cobot/cobot_backend.hpp"
#include "device/cobot/scripted_operator.hpp"
#include "device/cobot/tracking_stability.hpp"
#include "device/cobot/unicycle_cobot.hpp"
#include "scenarios.hpp"
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
                           double arrow_mm_per_N, int arrow_every, bool equal_axes, const std::string& key = "below") {
  std::ostringstream gp;
  gp << "set terminal png size 900,700\nset output '" << png << "'\nset datafile separator ','\n"
     << "set title '" << title << "' noenhanced\nset xlabel 'x (mm)'\nset ylabel 'y (mm)'\nset grid\nset key " << key
     << " box opaque\nset clip two\n";
  if (key == "below") {
    // gnuplot puts a key below the axes over the x label unless the bottom margin leaves room for both: one line for
    // the tick labels, one for the x label, one per key entry (an upper bound) and the box.
    const std::size_t entries = runs.size() + 1 + (wall_csv.empty() ? 0 : 1);
    gp << "set bmargin " << 4 + entries << "\n";
  }
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
       << "):($8*" << arrow_mm_per_N << ") with vectors head filled lc " << colour;
    if (colour == 1) {  // one legend entry for the arrows of every run
      gp << " title 'operator force (" << std::setprecision(3) << arrow_mm_per_N << " mm/N"
         << (equal_axes ? "" : " per axis; axes not to scale") << ")'";
    } else {
      gp << " notitle";
    }
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
    std::string gp = TrajectoryPlot(png, title.str(), {{o.common.output + ".csv", "cart (virtual caster)"}}, "",
                                    CasterArrowScale_mm_per_N(o, config), 100, true);
    // The turn is taller than wide and the axes are to scale: a portrait canvas, or the axes fill its middle only.
    const std::string terminal = "set terminal png size 900,700\n";
    gp.replace(gp.find(terminal), terminal.size(), "set terminal png size 800,1000\n");
    RunGnuplot(o.common.output + ".gp", gp);
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
    // The trajectory on top; below it p(t), where the millimetre penetration and steady-state error are visible
    // (at the trajectory's 600 mm scale they are not).
    std::string gp =
        TrajectoryPlot(o.common.output + ".png", title.str(), {{csv, "cart"}}, wall_csv, 4.0, 60, o.path == "circle");
    const std::string terminal = "set terminal png size 900,700\n";
    gp.replace(gp.find(terminal), terminal.size(), "set terminal png size 900,1100\n");
    const std::size_t output_end = gp.find('\n', gp.find("set output")) + 1;
    gp.insert(output_end, "set multiplot\nset origin 0,0.33\nset size 1,0.67\n");
    gp +=
        "set origin 0,0\nset size noratio 1,0.33\nset bmargin 3\nset title 'penetration p(t)' noenhanced\n"
        "set xlabel 't (s)'\nset ylabel 'p (mm)'\nset key top right box opaque\nplot '" +
        csv +
        "' skip 1 using 1:($13*1000) with lines lw 2 lc 1 title 'p (> 0: inside the wall)', 0 with lines "
        "dt 2 lc rgb 'black' notitle\nunset multiplot\n";
    RunGnuplot(o.common.output + ".gp", gp);
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
    WriteConstraintCsv(wall_csv, Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true), 0.0, 0.5);
    std::ostringstream title;
    title << "cobot-wall (" << o.vehicle << "): max penetration " << std::setprecision(3) << r.max_penetration_m * 1e3
          << " mm with overlay " << o.overlay << ", " << other.max_penetration_m * 1e3 << " mm with it "
          << (overlay ? "off" : "on");
    std::string script = TrajectoryPlot(
        o.common.output + ".png", title.str(),
        {{csv, std::string("overlay ") + o.overlay}, {other_csv, std::string("overlay ") + (overlay ? "off" : "on")}},
        wall_csv, 2.0, 30, false, "inside bottom right");
    // The whole run (0 to 500 mm along the wall) and the tips of the force arrows (up to about 41 mm with the
    // overlay off) inside the axes; the key in the empty lower-right corner.
    script = "set xrange [0:500]\nset yrange [-160:50]\nset xtics 50\nset ytics 20\n" + script;
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
  std::string path = "line";      ///< line, or circle (radius_m, kept inside): eq 10 proper.
  double radius_m = 0.2;
  std::string gain_form = "small_angle";  ///< small_angle (eq 8) or circular (eq 7).
  double integral_scale = 0.0;            ///< Integral gain k_i = integral_scale / L³ (0 = none, as eqs 9-10).
  double initial_offset_m = 0.002;
  double arc_lookaheads = 60.0;  ///< Run length in lookahead distances.
};

device::cobot::ConstraintTrackerConfig::GainForm GainFormOf(const std::string& form) {
  if (form == "small_angle") return device::cobot::ConstraintTrackerConfig::GainForm::kSmallAngle;
  if (form == "circular") return device::cobot::ConstraintTrackerConfig::GainForm::kCircular;
  throw Error("--gain-form must be small_angle (eq 8) or circular (eq 7), got '" + form + "'");
}

/// The largest real part of the roots of the linearized tracking loop with integral action, per unit arc length:
/// p' = θ, θ' = −κ²p − κ̃, T·κ̃' = a·p + b·θ + c·∫p ds − κ̃ (T = uτ, κ = 1/ρ), i.e.
/// T·s⁴ + s³ + (Tκ² + b)·s² + (κ² + a)·s + c = 0 (c = 0: the cubic of eq 9 times s).
double GrowthWithIntegral(double speed_tau_m, double curvature_per_m, double a, double b, double c) {
  const double k2 = curvature_per_m * curvature_per_m;
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = -1.0 / speed_tau_m;
  m(0, 1) = -(speed_tau_m * k2 + b) / speed_tau_m;
  m(0, 2) = -(k2 + a) / speed_tau_m;
  m(0, 3) = -c / speed_tau_m;
  m(1, 0) = 1.0;
  m(2, 1) = 1.0;
  m(3, 2) = 1.0;
  const Eigen::EigenSolver<Eigen::Matrix4d> solver(m, false);
  Eigen::Vector4d re = solver.eigenvalues().real();
  if (c == 0.0) {  // drop the root s = 0 the multiplication by s added
    int zero = 0;
    re.cwiseAbs().minCoeff(&zero);
    re(zero) = -std::numeric_limits<double>::infinity();
  }
  return re.maxCoeff();
}

/// The simulation's own loop on a line, linearized but not made continuous: one 1 kHz cycle of UnicycleCobot::Step
/// (ideal sensors, constant u, no slip, b = 0) maps x_k = (p, ψ, ω, ω̂_{k−1}) to x_{k+1}:
///   ω̂_k = ω̂_{k−1} + α·(ω_k − ω̂_{k−1})        the backward difference (ψ_k − ψ_{k−1})/h = ω_k, low-passed
///   ω_c = −u·(a·p_k + b·ψ_k)                   eq 8, p and θ = ψ measured at the start of the cycle
///   ω_{k+1} = ω_k + (h/τ)·(ω_c − ω̂_k)          J·ω̇ = K₂(ω_c − ω̂), explicit in the torque
///   ψ_{k+1} = ψ_k + h·ω_{k+1},  p_{k+1} = p_k + h·u·ψ_k    (semi-implicit heading, position on the old heading)
/// Its largest |eigenvalue| is 1 on the boundary.
double DiscreteGrowth(double u, double tau_s, double h, double alpha, double a, double b) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  // Rows: p, ψ, ω, ω̂ (next), in terms of (p, ψ, ω, ω̂_prev).
  const double g = h / tau_s;
  // ω̂_k = (1 − α)·ω̂_prev + α·ω
  const Eigen::RowVector4d rate(0.0, 0.0, alpha, 1.0 - alpha);
  const Eigen::RowVector4d command(-u * a, -u * b, 0.0, 0.0);
  const Eigen::RowVector4d omega_next = Eigen::RowVector4d(0.0, 0.0, 1.0, 0.0) + g * (command - rate);
  m.row(0) << 1.0, h * u, 0.0, 0.0;
  m.row(2) = omega_next;
  m.row(1) = Eigen::RowVector4d(0.0, 1.0, 0.0, 0.0) + h * omega_next;
  m.row(3) = rate;
  const Eigen::EigenSolver<Eigen::Matrix4d> solver(m, false);
  return solver.eigenvalues().cwiseAbs().maxCoeff();
}

double DiscreteBoundary_m_per_s(const StabilityOptions& o, double tau_s, double lookahead_m) {
  const device::cobot::TrackingGains g = device::cobot::ComputeTrackingGains(GainFormOf(o.gain_form), lookahead_m, 0.0);
  const double alpha = 1.0 - std::exp(-2.0 * std::numbers::pi * o.rate_filter_hz * o.step_s);
  double lo = 1e-6;
  double hi = 10.0 * lookahead_m / tau_s;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (DiscreteGrowth(mid, tau_s, o.step_s, alpha, g.p_per_m2, g.theta_per_m) < 1.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// The linear model's boundary: the speed where GrowthWithIntegral crosses 0 (bisection).
double LinearBoundary_m_per_s(const StabilityOptions& o, double tau_s, double lookahead_m) {
  const double curvature = o.path == "circle" ? 1.0 / o.radius_m : 0.0;
  const device::cobot::TrackingGains g =
      device::cobot::ComputeTrackingGains(GainFormOf(o.gain_form), lookahead_m, curvature);
  const double c = o.integral_scale / std::pow(lookahead_m, 3);
  double lo = 1e-6;
  double hi = 10.0 * lookahead_m / tau_s;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (GrowthWithIntegral(mid * tau_s, curvature, g.p_per_m2, g.theta_per_m, c) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Bilateral line tracking from a 2 mm offset at constant speed. Returns the late/early amplitude ratio of p
/// (max |p| over the last quarter of the run over max |p| over the second quarter), or 0 when p has settled below
/// 5 % of the offset (converged to the sensor noise); at least 1 when the late amplitude is still above the offset
/// (a limit cycle is not convergence). Converging: the returned value is < 1.
constexpr double kConvergedRatio = 1.0;

/// Late over early amplitude of p, 0 when the late one is below 5 % of the start offset, at least 1 when it is at or
/// above `limit_cycle_m` (a limit cycle, however slowly it shrinks, is not convergence).
double ConvergenceRatio(double early_m, double late_m, double initial_offset_m, double limit_cycle_m) {
  if (late_m < 0.05 * initial_offset_m) return 0.0;
  const double ratio = late_m / std::max(early_m, 1e-12);
  return late_m >= limit_cycle_m ? std::max(ratio, kConvergedRatio) : ratio;
}

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
  c.controller.tracker.gain_form = GainFormOf(o.gain_form);
  c.controller.tracker.integral_gain_per_m3 = o.integral_scale / std::pow(lookahead_m, 3);
  c.controller.tracker.integral_limit_m2 = 1e3;
  c.controller.overlay_enabled = false;
  c.controller.release_distance_m = 10.0;  // bilateral, as analysed
  c.controller.release_force_N = 1e6;
  c.controller.guard.margin = 1.0;  // warn only (the default action): the run measures the boundary itself
  c.steering_rate_filter.cutoff_hz = o.rate_filter_hz;
  const double kInitialOffset_m = o.initial_offset_m;
  const bool circle = o.path == "circle";
  // The circle is kept inside (forbidden outside); the cart starts at its bottom, moving along +x (anticlockwise).
  const Constraint wall = circle ? Constraint::Circle({0.0, 0.0}, o.radius_m, /*forbidden_outside=*/true)
                                 : Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  UnicyclePlantState initial;
  initial.position_m = circle ? Vec2(0.0, -(o.radius_m - kInitialOffset_m)) : Vec2(0.0, kInitialOffset_m);
  initial.speed_m_per_s = speed_m_per_s;
  // On the circle the wheel already turns at the path's rate u/ρ (the equilibrium of eq 5 is κ̃ = 0, not κ = 0).
  if (circle) initial.steering_rate_rad_per_s = speed_m_per_s / o.radius_m;
  UnicycleCobot cobot(c, wall, initial);
  device::cobot::PushingOperatorConfig op_config;
  op_config.speed_m_per_s = speed_m_per_s;
  op_config.push_angle_rad = 0.0;
  op_config.max_force_N = 500.0;
  device::cobot::PushingOperator op(op_config, wall);
  const double arc_m = o.arc_lookaheads * lookahead_m;
  const int steps = static_cast<int>(std::clamp(arc_m / speed_m_per_s, 1.0, 200.0) / o.step_s);
  const double diverged_m = circle ? 0.25 * o.radius_m : 0.2;  // off by a quarter of the radius: not tracking
  double early_min = std::numeric_limits<double>::infinity();
  double early_max = -early_min;
  double late_min = early_min;
  double late_max = -early_min;
  for (int k = 0; k < steps; ++k) {
    const auto s = cobot.Step(op.Step(cobot.state(), o.step_s), o.step_s);
    const double p = wall.Evaluate(s.position_m).penetration_m;
    if (!std::isfinite(p) || std::abs(p) > diverged_m) return 1e3;  // diverged
    if (k >= steps / 4 && k < steps / 2) {
      early_min = std::min(early_min, p);
      early_max = std::max(early_max, p);
    }
    if (k >= 3 * steps / 4) {
      late_min = std::min(late_min, p);
      late_max = std::max(late_max, p);
    }
  }
  // On a circle at speed p settles to a small offset, and with L near ρ two poles are lightly damped (§4.1), so the
  // transient first grows above the start offset and then decays slowly: there the amplitude is taken about each
  // window's mean, and a late amplitude of 5 start offsets or more is a limit cycle, not convergence (late below early
  // alone let the 25–40 mm cycles at small L count as converged). On the line a late amplitude at or above the start
  // offset is one. On both a late amplitude below 5 % of the offset has settled to the sensors' noise (late over
  // early there is noise over noise).
  const double early = circle ? 0.5 * (early_max - early_min) : std::max(std::abs(early_min), std::abs(early_max));
  const double late = circle ? 0.5 * (late_max - late_min) : std::max(std::abs(late_min), std::abs(late_max));
  return ConvergenceRatio(early, late, kInitialOffset_m, (circle ? 5.0 : 1.0) * kInitialOffset_m);
}

int RunStability(const StabilityOptions& o) {
  if (!(o.rate_filter_hz > 0.0) || !(o.step_s > 0.0 && o.step_s <= 0.01)) {
    throw Error("cobot-stability: --rate-filter-hz must be > 0 and --step-s in (0, 0.01]");
  }
  if (o.path != "line" && o.path != "circle") throw Error("cobot-stability: --path must be line or circle");
  if (!(o.radius_m > 0.0) || !(o.integral_scale >= 0.0) || !(o.initial_offset_m > 0.0) ||
      !(o.arc_lookaheads >= 8.0 && o.arc_lookaheads <= 10000.0)) {
    throw Error(
        "cobot-stability: --radius-m and --initial-offset-m must be > 0, --integral-scale >= 0, --arc-lookaheads "
        "8..10000");
  }
  (void)GainFormOf(o.gain_form);
  const std::string csv_path = o.common.output + ".csv";
  const std::string boundary_path = o.common.output + "_boundary.csv";
  std::ofstream csv = OpenCsv(csv_path);
  std::ofstream boundary = OpenCsv(boundary_path);
  csv << "tau_s,lookahead_m,speed_m_per_s,u_tau_m,u_tau_over_L,growth_ratio,stable_sim,stable_eq10\n";
  boundary << "tau_s,lookahead_m,u_max_eq10_m_per_s,u_max_sim_m_per_s,u_tau_sim_m,u_tau_linear_m\n";
  std::ostringstream json;
  json << std::setprecision(6) << "{\"scenario\":\"cobot-stability\",\"pairs\":[";
  bool first = true;
  for (const double tau : o.tau_s) {
    for (const double lookahead : o.lookahead_m) {
      device::cobot::ConstraintTrackerConfig tracker;
      tracker.lookahead_m = lookahead;
      tracker.gain_form = GainFormOf(o.gain_form);
      const double curvature = o.path == "circle" ? 1.0 / o.radius_m : 0.0;
      // Eq 10 (eq 7's gains: uτ/ρ < tan φ) or eq 11 (eq 8's: uτ < L), without integral action.
      const double u_eq10 = device::cobot::MaxStableSpeed_m_per_s(tracker, tau, curvature);
      const double u_eq11 = lookahead / tau;
      const double u_linear = LinearBoundary_m_per_s(o, tau, lookahead);
      const bool discrete_applies = o.path == "line" && o.integral_scale == 0.0;
      const double u_discrete = discrete_applies ? DiscreteBoundary_m_per_s(o, tau, lookahead) : 0.0;
      const double u_formula = u_linear;  // the sweep's speeds are multiples of the linear model's boundary
      for (const double ratio : o.ratios) {
        const double u = ratio * u_formula;
        const double growth = TrackingGrowth(o, u, tau, lookahead);
        csv << tau << ',' << lookahead << ',' << u << ',' << u * tau << ',' << ratio << ',' << growth << ','
            << (growth < kConvergedRatio ? 1 : 0) << ',' << (ratio < 1.0 ? 1 : 0) << '\n';
      }
      // The simulated boundary: the lowest speed where tracking stops converging. Stability need not be monotonic
      // in u, so a scan from 0.25 to 3 times the linear model's boundary (0.25 steps) finds the first unstable
      // speed, and the bisection runs between it and the stable one before it. Unstable already at 0.25: reported
      // as 0.25 × (an upper bound); stable throughout: 3 × (a lower bound).
      double lo = 0.0;
      double hi = 0.0;
      bool bracketed = false;
      for (double r = 0.25; r <= 3.0 + 1e-9; r += 0.25) {
        const bool stable = TrackingGrowth(o, r * u_formula, tau, lookahead) < kConvergedRatio;
        if (!stable) {
          hi = r * u_formula;
          bracketed = r > 0.25;
          break;
        }
        lo = r * u_formula;
      }
      if (hi == 0.0) {
        hi = lo;  // stable up to the top of the range
      } else if (!bracketed) {
        lo = hi;  // unstable at the bottom of the range
      } else {
        for (int i = 0; i < 9; ++i) {
          const double mid = 0.5 * (lo + hi);
          (TrackingGrowth(o, mid, tau, lookahead) < kConvergedRatio ? lo : hi) = mid;
        }
      }
      const double u_sim = 0.5 * (lo + hi);
      boundary << tau << ',' << lookahead << ',' << u_eq10 << ',' << u_sim << ',' << u_sim * tau << ','
               << u_linear * tau << '\n';
      json << (first ? "" : ",") << "{\"tau_s\":" << tau << ",\"lookahead_m\":" << lookahead
           << ",\"u_max_eq10_m_per_s\":" << u_eq10 << ",\"u_max_eq11_m_per_s\":" << u_eq11
           << ",\"u_max_linear_m_per_s\":" << u_linear;
      if (discrete_applies) json << ",\"u_max_discrete_m_per_s\":" << u_discrete;
      json << ",\"u_max_sim_m_per_s\":" << u_sim << "}";
      first = false;
      if (!o.common.json) {
        std::cout << "tau " << tau << " s, L " << lookahead << " m: eq 10 u_max = " << u_eq10
                  << " m/s, eq 11 (u tau < L) " << u_eq11 << " m/s, linear model (with the integral) " << u_linear
                  << " m/s, simulation u_max = " << u_sim << " m/s (sim/linear " << u_sim / u_linear << ")\n";
      }
    }
  }
  csv.close();
  boundary.close();
  json << "]}";
  if (!o.common.no_plot) {
    // The title names what was run; on a circle with eq 7's gains the eq 10 curve u tau = rho tan(L/rho), i.e.
    // L = rho atan(u tau / rho), is drawn beside eq 11's line; with the integral, the linearized loop's boundary.
    const bool circle = o.path == "circle";
    const bool eq7 = o.gain_form == "circular";
    const double rho_mm = o.radius_m * 1000.0;
    std::ostringstream title;
    title << "cobot-stability: ";
    if (circle) {
      title << "circle rho = " << rho_mm << " mm";
    } else {
      title << "line";
    }
    title << ", " << (eq7 && circle ? "eq 7" : "eq 8") << " gains";
    if (o.integral_scale > 0.0) title << ", integral k_i = " << o.integral_scale << "/L^3";
    std::ostringstream gp;
    gp << "set terminal png size 900,700\nset output '" << o.common.output << ".png'\nset datafile separator ','\n"
       << "set title '" << title.str() << "' noenhanced\n"
       << "set xlabel 'u*tau (mm)'\nset ylabel 'lookahead L (mm)'\nset grid\nset key top left box opaque\n"
       << "set logscale xy\nset samples 400\n"
       << "plot '" << csv_path << "' skip 1 using ($7==1 ? $4*1000 : 1/0):($2*1000) with points pt 7 ps 1.5 lc rgb "
       << "'forest-green' title 'simulation: converges', '" << csv_path
       << "' skip 1 using ($7==0 ? $4*1000 : 1/0):($2*1000) with points pt 5 ps 1.5 lc rgb 'red' title "
       << "'simulation: oscillates/diverges', '" << boundary_path
       << "' skip 1 using ($5*1000):($2*1000) with points pt 3 ps 3 lw 2 lc rgb 'black' title "
       << "'simulated boundary (bisection)', x with lines lw 2 lc rgb 'blue' title 'eq 11: u tau = L'";
    if (circle && eq7) {
      gp << ", " << rho_mm << "*atan(x/" << rho_mm << ") with lines lw 2 dt 2 lc rgb 'dark-orange' title "
         << "'eq 10: u tau = rho tan(L/rho)'";
    }
    if (o.integral_scale > 0.0) {
      gp << ", '" << boundary_path << "' skip 1 using ($6*1000):($2*1000) with points pt 6 ps 3 lw 2 lc rgb "
         << "'purple' title 'linearized loop with the integral (quartic)'";
    }
    gp << "\n";
    RunGnuplot(o.common.output + ".gp", gp.str());
  }
  if (o.common.json) {
    std::cout << json.str() << "\n";
  } else {
    std::cout << "  " << csv_path << ", " << boundary_path << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- cobot-turns (Fig. 4's force in sharp turns)

struct TurnsOptions {
  CommonOptions common;
  std::vector<double> speeds_m_per_s{0.005, 0.01, 0.02, 0.05, 0.1, 0.2};
  double turn_rate_rad_per_s = 1.0;
  double duration_s = 6.0;
};

/// Steady turning at `speed` and turn rate ω in caster mode: the mean lateral force over the second half (N), and the
/// mean speed and u·ω reached.
struct TurnResult {
  double speed_m_per_s = 0.0;
  double lateral_force_N = 0.0;
  double lateral_acceleration_m_per_s2 = 0.0;
};

TurnResult SteadyTurn(double speed_m_per_s, double lateral_acceleration_m_per_s2, double duration_s,
                      device::cobot::CobotSample* last = nullptr) {
  UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  UnicyclePlantState initial;
  initial.speed_m_per_s = speed_m_per_s;
  UnicycleCobot cobot(config, Constraint::Line({0.0, 1e3}, {1.0, 0.0}, true), initial);
  cobot.controller().SetWallActive(false);
  device::cobot::TurningOperatorConfig op_config;
  op_config.speed_m_per_s = speed_m_per_s;
  op_config.lateral_acceleration_m_per_s2 = lateral_acceleration_m_per_s2;
  device::cobot::TurningOperator op(op_config);
  const int steps = static_cast<int>(duration_s / kPeriod_s);
  TurnResult r;
  int n = 0;
  for (int k = 0; k < steps; ++k) {
    const auto sample = cobot.Step(op.Step(cobot.state(), kPeriod_s), kPeriod_s);
    if (k >= steps / 2) {
      r.lateral_force_N += sample.lateral_force_N;
      r.lateral_acceleration_m_per_s2 += sample.lateral_acceleration_m_per_s2;
      r.speed_m_per_s += sample.speed_m_per_s;
      ++n;
    }
    if (last != nullptr) *last = sample;
  }
  r.lateral_force_N /= n;
  r.lateral_acceleration_m_per_s2 /= n;
  r.speed_m_per_s /= n;
  return r;
}

int RunTurns(const TurnsOptions& o) {
  if (o.speeds_m_per_s.empty() || !(o.turn_rate_rad_per_s > 0.0) || !(o.duration_s > 2.0)) {
    throw Error("cobot-turns: --speeds-m-s must not be empty, --turn-rate-rad-s > 0, --duration-s > 2");
  }
  for (const double u : o.speeds_m_per_s) {
    if (!(u > 0.0)) throw Error("cobot-turns: --speeds-m-s must be > 0");
  }
  const UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  const double mass = 1.0 / config.controller.caster.k1_per_kg;
  const double floor = config.controller.caster.speed_floor_m_per_s;
  const std::string csv_path = o.common.output + ".csv";
  std::ofstream csv = OpenCsv(csv_path);
  csv << "speed_m_per_s,lateral_force_N,point_mass_force_N,eq2_force_N,rolling_force_N\n";
  std::ostringstream json;
  json << std::setprecision(6) << "{\"scenario\":\"cobot-turns\",\"turn_rate_rad_per_s\":" << o.turn_rate_rad_per_s
       << ",\"virtual_mass_kg\":" << mass << ",\"speed_floor_m_per_s\":" << floor << ",\"turns\":[";
  for (std::size_t i = 0; i < o.speeds_m_per_s.size(); ++i) {
    const double u = o.speeds_m_per_s[i];
    const TurnResult r = SteadyTurn(u, u * o.turn_rate_rad_per_s, o.duration_s);
    // At the turn rate actually reached: ω = (u·ω)/u.
    const double omega = r.lateral_acceleration_m_per_s2 / r.speed_m_per_s;
    const double point_mass = mass * r.speed_m_per_s * omega;
    const double eq2 = mass * std::max(r.speed_m_per_s, floor) * omega;
    const double rolling = config.plant.rolling_damping_Ns_per_m * r.speed_m_per_s;
    csv << r.speed_m_per_s << ',' << r.lateral_force_N << ',' << point_mass << ',' << eq2 << ',' << rolling << '\n';
    json << (i == 0 ? "" : ",") << "{\"speed_m_per_s\":" << r.speed_m_per_s << ",\"turn_rate_rad_per_s\":" << omega
         << ",\"lateral_force_N\":" << r.lateral_force_N << ",\"point_mass_force_N\":" << point_mass
         << ",\"eq2_force_N\":" << eq2 << ",\"rolling_force_N\":" << rolling << "}";
    if (!o.common.json) {
      std::cout << "u " << r.speed_m_per_s << " m/s, turn rate " << omega << " rad/s: lateral force "
                << r.lateral_force_N << " N (point mass M u w = " << point_mass << " N, eq 2 M max(u, eps) w = " << eq2
                << " N; rolling " << rolling << " N)\n";
    }
  }
  csv.close();
  json << "]}";
  if (!o.common.no_plot) {
    std::ostringstream gp;
    gp << "set terminal png size 900,650\nset output '" << o.common.output << ".png'\nset datafile separator ','\n"
       << "set title 'cobot-turns: lateral force of a turn at " << o.turn_rate_rad_per_s
       << " rad/s against speed (virtual caster, eq 2)' noenhanced\n"
       << "set xlabel 'speed u (m/s)'\nset ylabel 'force (N)'\nset grid\nset logscale xy\n"
       << "set key top left box opaque\nset format x '%g'\nset format y '%g'\n"
       << "plot '" << csv_path << "' skip 1 using 1:2 with points pt 7 ps 1.8 lc rgb 'red' title "
       << "'simulated cobot: lateral force', '" << csv_path
       << "' skip 1 using 1:3 with lines lw 2 lc rgb 'blue' title 'point mass: M u w', '" << csv_path
       << "' skip 1 using 1:4 with lines lw 2 dt 2 lc rgb 'black' title 'eq 2: M max(u, eps) w', '" << csv_path
       << "' skip 1 using 1:5 with lines lw 2 lc rgb 'forest-green' title 'rolling resistance c u (the push along)'\n";
    RunGnuplot(o.common.output + ".gp", gp.str());
  }
  std::cout << (o.common.json ? json.str() + "\n" : "  " + csv_path + "\n");
  return 0;
}

// ---------------------------------------------------------------- cobot-slip (friction-limited traction)

struct SlipOptions {
  CommonOptions common;
  double mu = 0.5;
  double speed_m_per_s = 0.2;
  double ramp_N_per_s = 20.0;  ///< The push into the wall grows at this rate.
  double duration_s = 4.0;
};

int RunSlip(const SlipOptions& o) {
  if (!(o.mu > 0.0) || !(o.speed_m_per_s > 0.0) || !(o.ramp_N_per_s > 0.0) || !(o.duration_s > 0.5)) {
    throw Error("cobot-slip: --mu, --speed-m-s and --ramp-n-s must be > 0, --duration-s > 0.5");
  }
  UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  config.plant.friction_coefficient = o.mu;
  config.plant.max_steering_torque_Nm = 5.0;
  const double limit_N = device::cobot::TractionLimit_N(config.plant);
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);  // forbidden y > 0
  UnicyclePlantState initial;
  initial.position_m = {0.0, -0.001};
  initial.speed_m_per_s = o.speed_m_per_s;
  UnicycleCobot cobot(config, wall, initial);
  const std::string csv_path = o.common.output + ".csv";
  std::ofstream csv = OpenCsv(csv_path);
  csv << "t_s,push_into_wall_N,lateral_load_N,floor_lateral_N,penetration_m,sliding,mode\n";
  double speed_integral = 0.0;
  double breakaway_s = -1.0;
  double breakaway_push_N = 0.0;
  double breakaway_lateral_N = 0.0;
  double max_p_before = 0.0;
  double p_end = 0.0;
  const int steps = static_cast<int>(o.duration_s / kPeriod_s);
  for (int k = 0; k < steps; ++k) {
    const double t = k * kPeriod_s;
    const UnicyclePlantState& st = cobot.state();
    // Along the wall: a PI on the speed; into it: a push that keeps growing (a "hard push").
    const double error = o.speed_m_per_s - st.speed_m_per_s;
    speed_integral = std::clamp(speed_integral + 500.0 * error * kPeriod_s, 0.0, 100.0);
    const double along = std::clamp(200.0 * error + speed_integral, 0.0, 100.0);
    const double into = o.ramp_N_per_s * t;
    const Vec2 force(along, into);
    const auto sample = cobot.Step(force, kPeriod_s);
    const UnicyclePlantState& after = cobot.state();
    const double p = wall.Evaluate(after.position_m).penetration_m;
    const double lateral = force.dot(device::cobot::LeftNormal(device::cobot::UnitAt(after.heading_rad))) -
                           config.plant.cart_mass_kg * after.speed_m_per_s * after.steering_rate_rad_per_s;
    if (breakaway_s < 0.0 && after.sliding) {
      breakaway_s = t;
      breakaway_push_N = into;
      breakaway_lateral_N = lateral;
    }
    if (breakaway_s < 0.0) max_p_before = std::max(max_p_before, p);
    p_end = p;
    if (k % 5 == 0) {
      csv << t << ',' << into << ',' << lateral << ',' << device::cobot::FloorLateralForce_N(config.plant, after, force)
          << ',' << p << ',' << (after.sliding ? 1 : 0) << ',' << static_cast<int>(sample.control.mode) << '\n';
    }
  }
  csv.close();
  if (!o.common.no_plot) {
    std::ostringstream gp;
    gp << "set terminal png size 900,800\nset output '" << o.common.output << ".png'\nset datafile separator ','\n"
       << "set multiplot layout 2,1 title 'cobot-slip: a hard push into a virtual wall, mu = " << o.mu
       << ", mu N = " << std::setprecision(3) << limit_N << " N' noenhanced\n"
       << "set grid\nset xlabel 't (s)'\nset key top left box opaque\n"
       << "set ylabel 'force (N)'\nplot '" << csv_path
       << "' skip 1 using 1:2 with lines lw 2 lc rgb 'blue' title 'push into the wall', '" << csv_path
       << "' skip 1 using 1:(-$4) with lines lw 2 lc rgb 'red' title 'lateral force the floor carries', '" << csv_path
       << "' skip 1 using 1:3 with lines lw 1 dt 3 lc rgb 'dark-red' title 'lateral load without slip (demand)', "
       << limit_N << " with lines lw 2 dt 2 lc rgb 'black' title 'traction limit mu N'\n"
       << "set ylabel 'penetration p (mm)'\nset yrange [-5:60]\n"
       << "# ranges: y clipped (the wheel slides and the penetration runs away; the key says so)\nplot '" << csv_path
       << "' skip 1 using 1:($5*1000) with lines lw 2 lc rgb 'red' title 'penetration into the wall (clipped at 60 "
          "mm)', '"
       << csv_path << "' skip 1 using 1:($6*50) with steps lw 2 lc rgb 'gray' title 'sliding (50 = yes)'\n"
       << "unset multiplot\n";
    RunGnuplot(o.common.output + ".gp", gp.str());
  }
  if (o.common.json) {
    std::cout << std::setprecision(6) << "{\"scenario\":\"cobot-slip\",\"mu\":" << o.mu
              << ",\"traction_limit_N\":" << limit_N << ",\"breakaway_s\":" << breakaway_s
              << ",\"breakaway_push_N\":" << breakaway_push_N << ",\"breakaway_lateral_load_N\":" << breakaway_lateral_N
              << ",\"max_penetration_before_mm\":" << max_p_before * 1e3 << ",\"penetration_end_mm\":" << p_end * 1e3
              << "}\n";
  } else {
    std::cout << "cobot-slip: traction limit mu N = " << limit_N << " N; the wheel broke traction at " << breakaway_s
              << " s, push " << breakaway_push_N << " N (lateral load " << breakaway_lateral_N
              << " N); penetration before " << max_p_before * 1e3 << " mm, at the end " << p_end * 1e3 << " mm\n  "
              << csv_path << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- cobot-heading (the bicycle's angular constraint)

struct HeadingOptions {
  CommonOptions common;
  double initial_error_deg = 20.0;
  double bandwidth_per_s = 2.0;
  double speed_m_per_s = 0.2;
  double push_direction_deg = 30.0;
  double duration_s = 4.0;
};

struct HeadingRun {
  double max_model_error_rad = 0.0;  ///< max |θ(t) − e₀(1 + ω_h t)e^(−ω_h t)|
  double final_theta_rad = 0.0;
  double travel_direction_deg = 0.0;  ///< Direction of the final velocity (deg).
  double push_direction_deg = 0.0;
};

HeadingRun RunHeadingOnce(const HeadingOptions& o, bool constrained, const std::string& csv_path) {
  device::cobot::BicyclePlantConfig plant;
  plant.geometry.handle_m = {0.1, 0.15};  // off centre: the push has a moment about the plate origin
  device::cobot::BicycleCasterConfig caster;
  caster.virtual_mass_kg = plant.plate_mass_kg;
  caster.virtual_inertia_kgm2 = plant.plate_inertia_kgm2;
  caster.k2_Nms_per_rad = plant.steering_inertia_kgm2 / 0.02;  // τ = 20 ms (no steering friction in this plant)
  caster.rolling_damping_Ns_per_m = plant.rolling_damping_Ns_per_m;
  caster.heading_constraint = constrained;
  caster.heading_target_rad = 0.0;
  caster.heading_bandwidth_per_s = o.bandwidth_per_s;
  device::cobot::BicyclePlantState s;
  const double e0 = o.initial_error_deg * kDegToRad;
  s.pose.angle_rad = e0;
  s.steer_rad = {-e0, -e0};  // both wheels along world +x
  s.twist << o.speed_m_per_s, 0.0, 0.0;
  // The caster sees the plate as the device's does: the Prototype's encoders and force sensor, the rates estimated.
  const device::cobot::UnicycleCobotConfig rig = device::cobot::UnicycleCobotConfig::Prototype();
  device::cobot::BicycleSensing sensing(rig.sensors, rig.speed_filter, rig.steering_rate_filter, plant.geometry);
  sensing.Reset(s);
  const Vec2 direction = device::cobot::UnitAt(o.push_direction_deg * kDegToRad);
  std::ofstream csv = OpenCsv(csv_path);
  csv << "t_s,x_m,y_m,theta_rad,model_theta_rad,force_x_N,force_y_N\n";
  double integral = 0.0;
  HeadingRun r;
  r.push_direction_deg = o.push_direction_deg;
  const int steps = static_cast<int>(o.duration_s / kPeriod_s);
  const double w = o.bandwidth_per_s;
  for (int k = 0; k < steps; ++k) {
    const double speed = Vec2(s.twist(0), s.twist(1)).norm();
    const double error = o.speed_m_per_s - speed;
    integral = std::clamp(integral + 300.0 * error * kPeriod_s, 0.0, 60.0);
    const Vec2 force = std::clamp(100.0 * error + integral, 0.5, 60.0) * direction;
    const double step_N = rig.sensors.force_resolution_N;
    const Vec2 measured(device::cobot::Quantize(force.x(), step_N), device::cobot::Quantize(force.y(), step_N));
    const device::cobot::BicyclePlantState seen = sensing.Measure(s, kPeriod_s);
    const auto out = device::cobot::BicycleCasterStep(caster, plant.geometry, seen, measured, 0.0);
    device::cobot::BicyclePlantInput in;
    in.handle_force_N = force;
    in.steering_torque_Nm = out.steering_torque_Nm;
    device::cobot::Step(plant, in, kPeriod_s, s);
    sensing.Roll(s, kPeriod_s);
    const double t = (k + 1) * kPeriod_s;
    const double model = e0 * (1.0 + w * t) * std::exp(-w * t);
    if (constrained) r.max_model_error_rad = std::max(r.max_model_error_rad, std::abs(s.pose.angle_rad - model));
    if (k % 10 == 0) {
      csv << t << ',' << s.pose.position_m.x() << ',' << s.pose.position_m.y() << ',' << s.pose.angle_rad << ','
          << model << ',' << force.x() << ',' << force.y() << '\n';
    }
  }
  r.final_theta_rad = s.pose.angle_rad;
  r.travel_direction_deg = std::atan2(s.twist(1), s.twist(0)) / kDegToRad;
  return r;
}

int RunHeading(const HeadingOptions& o) {
  if (!(o.bandwidth_per_s > 0.0 && o.bandwidth_per_s <= 20.0) || !(o.speed_m_per_s > 0.0) || !(o.duration_s > 0.5)) {
    throw Error("cobot-heading: --bandwidth-per-s in (0, 20], --speed-m-s > 0, --duration-s > 0.5");
  }
  const std::string csv = o.common.output + ".csv";
  const std::string free_csv = o.common.output + "_free.csv";
  const HeadingRun held = RunHeadingOnce(o, true, csv);
  const HeadingRun free = RunHeadingOnce(o, false, free_csv);
  if (!o.common.no_plot) {
    std::ostringstream gp;
    gp << "set terminal png size 900,800\nset output '" << o.common.output << ".png'\nset datafile separator ','\n"
       << "set multiplot layout 2,1 title 'cobot-heading: bicycle, off-centre push at " << o.push_direction_deg
       << " deg, heading held at 0 by steering both wheels' noenhanced\n"
       << "set grid\nset key top right box opaque\nset xlabel 't (s)'\nset ylabel 'plate heading theta (deg)'\n"
       << "plot '" << csv
       << "' skip 1 using 1:($4*180/pi) with lines lw 3 lc rgb 'red' title 'angular constraint on', '" << csv
       << "' skip 1 using 1:($5*180/pi) with lines lw 2 dt 2 lc rgb 'black' title 'e0 (1 + w t) exp(-w t)', '"
       << free_csv << "' skip 1 using 1:($4*180/pi) with lines lw 2 lc rgb 'blue' title 'no angular constraint'\n"
       << "set xlabel 'x (mm)'\nset ylabel 'y (mm)'\nset size ratio -1\nset key top left box opaque\n"
       << "plot '" << csv << "' skip 1 using ($2*1000):($3*1000) with lines lw 3 lc rgb 'red' title "
       << "'plate origin, constraint on', '" << free_csv
       << "' skip 1 using ($2*1000):($3*1000) with lines lw 2 lc rgb 'blue' title 'plate origin, no constraint'\n"
       << "unset multiplot\n";
    RunGnuplot(o.common.output + ".gp", gp.str());
  }
  if (o.common.json) {
    std::cout << std::setprecision(6) << "{\"scenario\":\"cobot-heading\",\"initial_error_deg\":" << o.initial_error_deg
              << ",\"bandwidth_per_s\":" << o.bandwidth_per_s
              << ",\"max_model_error_deg\":" << held.max_model_error_rad / kDegToRad
              << ",\"final_theta_deg\":" << held.final_theta_rad / kDegToRad
              << ",\"free_final_theta_deg\":" << free.final_theta_rad / kDegToRad
              << ",\"travel_direction_deg\":" << held.travel_direction_deg
              << ",\"push_direction_deg\":" << o.push_direction_deg << "}\n";
  } else {
    std::cout << "cobot-heading: with the angular constraint theta ends at " << held.final_theta_rad / kDegToRad
              << " deg (largest departure from e0(1 + w t)exp(-w t): " << held.max_model_error_rad / kDegToRad
              << " deg); without it at " << free.final_theta_rad / kDegToRad << " deg\n  " << csv << "\n";
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
    sub->add_option("--path", o->path, "line, or circle (kept inside; eq 10 with rho = --radius-m)")
        ->capture_default_str();
    sub->add_option("--radius-m", o->radius_m, "Circle radius rho (m)")->capture_default_str();
    sub->add_option("--gain-form", o->gain_form, "small_angle (eq 8) or circular (eq 7)")->capture_default_str();
    sub->add_option("--integral-scale", o->integral_scale, "Integral gain k_i = scale / L^3 (0 = none)")
        ->capture_default_str();
    sub->add_option("--initial-offset-m", o->initial_offset_m, "Start offset from the constraint (m)")
        ->capture_default_str();
    sub->add_option("--arc-lookaheads", o->arc_lookaheads, "Run length per speed, in lookahead distances")
        ->capture_default_str();
    sub->callback([o] { RunStability(*o); });
  }
  {
    auto o = std::make_shared<TurnsOptions>();
    CLI::App* sub =
        app.add_subcommand("cobot-turns", "Fig. 4: lateral force of a turn against speed (eq 2's speed floor)");
    AddCommon(sub, o->common, "cobot_turns");
    sub->add_option("--speeds-m-s", o->speeds_m_per_s, "Speeds (m/s)")->delimiter(',');
    sub->add_option("--turn-rate-rad-s", o->turn_rate_rad_per_s, "Turn rate (rad/s)")->capture_default_str();
    sub->add_option("--duration-s", o->duration_s, "Run length per speed (s)")->capture_default_str();
    sub->callback([o] { RunTurns(*o); });
  }
  {
    auto o = std::make_shared<SlipOptions>();
    CLI::App* sub = app.add_subcommand("cobot-slip", "A hard push breaks the wheel's traction (mu N) at a wall");
    AddCommon(sub, o->common, "cobot_slip");
    sub->add_option("--mu", o->mu, "Friction coefficient of the wheel")->capture_default_str();
    sub->add_option("--speed-m-s", o->speed_m_per_s, "Speed along the wall (m/s)")->capture_default_str();
    sub->add_option("--ramp-n-s", o->ramp_N_per_s, "Growth of the push into the wall (N/s)")->capture_default_str();
    sub->add_option("--duration-s", o->duration_s, "Run length (s)")->capture_default_str();
    sub->callback([o] { RunSlip(*o); });
  }
  {
    auto o = std::make_shared<HeadingOptions>();
    CLI::App* sub = app.add_subcommand("cobot-heading", "The bicycle's angular constraint (theta held by the wheels)");
    AddCommon(sub, o->common, "cobot_heading");
    sub->add_option("--initial-error-deg", o->initial_error_deg, "Heading error at the start (deg)")
        ->capture_default_str();
    sub->add_option("--bandwidth-per-s", o->bandwidth_per_s, "omega_h of the return (rad/s)")->capture_default_str();
    sub->add_option("--speed-m-s", o->speed_m_per_s, "Speed the operator holds (m/s)")->capture_default_str();
    sub->add_option("--push-direction-deg", o->push_direction_deg, "Push direction (deg, world)")
        ->capture_default_str();
    sub->add_option("--duration-s", o->duration_s, "Run length (s)")->capture_default_str();
    sub->callback([o] { RunHeading(*o); });
  }
}

}  // namespace teleop::scenario
