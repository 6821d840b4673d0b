// Kwon & Song, "Force display using a hybrid haptic device composed of motors and brakes": the FME map (§2.2),
// the wall contact of §4 (Figs. 8, 9, Table 1) and the friction display of §5 (Figs. 11, 12) on the simulated rig.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>

#include "device/hybrid/force_manipulability.hpp"
#include "hybrid/contact_scenarios.hpp"
#include "scenarios.hpp"
#include "teleop/error.hpp"

namespace teleop::scenario {
namespace {

namespace hy = teleop::device::hybrid;

void RunGnuplot(const std::string& script_path, const std::string& script) {
  {
    std::ofstream gp(script_path);
    if (!gp) throw Error(script_path + ": cannot write the gnuplot script");
    gp << script;
  }
  const std::string command = "gnuplot '" + script_path + "' 2>&1";
  if (std::system(command.c_str()) != 0) {
    std::cerr << "teleop-scenario: gnuplot failed or is missing (script " << script_path << ")\n";
  }
}

std::ofstream OpenCsv(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot write the CSV");
  out << std::setprecision(9);
  return out;
}

struct FmeOptions {
  std::string output = "hybrid_fme";
  double grid_step_mm = 5.0;
  bool json = false;
  bool no_plot = false;
};

int RunFme(const FmeOptions& o) {
  const hy::HybridRigConfig rig{};
  const hy::FiveBar kinematics(rig.geometry);
  const hy::FmeMap map =
      hy::MapForceManipulability(kinematics, rig.motor.MaxJointTorqueNm(),
                                 rig.brake.max_torque_Nm * rig.brake.pulley_ratio, o.grid_step_mm * 1e-3);
  const std::string csv = o.output + ".csv";
  {
    std::ofstream out = OpenCsv(csv);
    out << "x_mm,y_mm,in_workspace,motor_min_force_N,brake_min_force_N,singularity_margin\n";
    for (int r = 0; r < map.rows; ++r) {
      for (int c = 0; c < map.columns; ++c) {
        const hy::FmeSample& s = map.samples[static_cast<std::size_t>(r) * static_cast<std::size_t>(map.columns) +
                                             static_cast<std::size_t>(c)];
        out << 1e3 * s.position_m.x() << ',' << 1e3 * s.position_m.y() << ',' << (s.in_workspace ? 1 : 0) << ','
            << s.motor_min_force_N << ',' << s.brake_min_force_N << ',' << s.singularity_margin << '\n';
      }
      out << '\n';  // gnuplot pm3d: one blank line per grid row.
    }
  }
  // Ellipses at a 4 x 3 grid of points, scaled for the plot (1 N = 0.1 mm), for the motors.
  const std::string ellipses = o.output + "_ellipses.csv";
  {
    std::ofstream out = OpenCsv(ellipses);
    out << "x_mm,y_mm\n";
    for (double x : {-0.150, -0.050, 0.050, 0.150}) {
      for (double y : {0.120, 0.200, 0.290}) {
        Eigen::Vector2d q;
        Eigen::Matrix2d jac;
        if (!kinematics.Inverse({x, y}, q) || !kinematics.Jacobian(q, jac)) continue;
        for (const auto& f : hy::FmeCurve(jac, rig.motor.MaxJointTorqueNm(), 73)) {
          out << 1e3 * x + 0.1 * f.x() << ',' << 1e3 * y + 0.1 * f.y() << '\n';
        }
        const auto first = hy::FmeCurve(jac, rig.motor.MaxJointTorqueNm(), 1).front();
        out << 1e3 * x + 0.1 * first.x() << ',' << 1e3 * y + 0.1 * first.y() << "\n\n";
      }
    }
  }
  if (!o.no_plot) {
    std::ostringstream gp;
    // Two equal-axis maps of a 400 x 250 mm workspace side by side: a canvas of about that shape leaves no blank bands
    // above and below them; the colour-bar label is offset clear of its tick labels.
    gp << "set terminal png size 1100,420\nset output '" << o.output << ".png'\nset datafile separator ','\n"
       << "set multiplot layout 1,2\nset size ratio -1\nset xlabel 'x (mm)'\nset ylabel 'y (mm)'\n"
       << "set cblabel 'min force (N)' offset 1.5,0\nset xrange [-200:200]\nset yrange [80:330]\n"
       // One colour scale for both maps, so that a colour is the same force in each.
       << "stats '" << csv << "' skip 1 using ($3>0?$4:1/0) name 'MOTOR' nooutput\n"
       << "stats '" << csv << "' skip 1 using ($3>0?$5:1/0) name 'BRAKE' nooutput\n"
       << "set cbrange [0:(MOTOR_max > BRAKE_max ? MOTOR_max : BRAKE_max)]\n"
       << "set title 'motors: min force in any direction (FME), ellipses: 1 N = 0.1 mm' noenhanced\n"
       << "plot '" << csv << "' skip 1 using 1:2:($3>0?$4:1/0) with image notitle, '" << ellipses
       << "' skip 1 using 1:2 with lines lc rgb 'black' notitle\n"
       << "set title 'brakes: min force in any direction (FME)' noenhanced\n"
       << "plot '" << csv << "' skip 1 using 1:2:($3>0?$5:1/0) with image notitle\nunset multiplot\n";
    RunGnuplot(o.output + ".gp", gp.str());
  }
  if (o.json) {
    std::cout << std::setprecision(6) << "{\"min_motor_force_N\": " << map.min_motor_force_N
              << ", \"min_brake_force_N\": " << map.min_brake_force_N << ", \"min_motor_at_mm\": ["
              << 1e3 * map.min_motor_at_m.x() << ", " << 1e3 * map.min_motor_at_m.y() << "], \"min_brake_at_mm\": ["
              << 1e3 * map.min_brake_at_m.x() << ", " << 1e3 * map.min_brake_at_m.y()
              << "], \"min_singularity_margin\": " << map.min_singularity_margin
              << ", \"workspace_points\": " << map.workspace_points << ", \"grid_step_mm\": " << o.grid_step_mm
              << ", \"motor_joint_torque_Nm\": " << rig.motor.MaxJointTorqueNm()
              << ", \"brake_joint_torque_Nm\": " << rig.brake.max_torque_Nm * rig.brake.pulley_ratio << "}\n";
  } else {
    std::cout << "FME over the workspace (" << map.workspace_points << " points, " << o.grid_step_mm
              << " mm grid):\n  motors: min " << map.min_motor_force_N << " N in any direction (at "
              << 1e3 * map.min_motor_at_m.x() << ", " << 1e3 * map.min_motor_at_m.y() << " mm); paper: > 80 N\n"
              << "  brakes: min " << map.min_brake_force_N << " N (at " << 1e3 * map.min_brake_at_m.x() << ", "
              << 1e3 * map.min_brake_at_m.y() << " mm); paper: > 36 N\n  smallest singularity margin "
              << map.min_singularity_margin << "\n  wrote " << csv << (o.no_plot ? "" : ", " + o.output + ".png")
              << "\n";
  }
  return 0;
}

void WriteSamples(const std::string& csv, const hy::ScenarioResult& r) {
  std::ofstream out = OpenCsv(csv);
  out << "t_s,x_mm,y_mm,vx_mm_s,vy_mm_s,depth_mm,rendered_normal_N,motor_normal_N,brake_normal_N,hand_normal_N,"
         "hand_tangent_N,rendered_tangent_N,friction_target_N,brake_capacity_1_Nm,brake_capacity_2_Nm,desired_normal_"
         "N\n";
  for (const auto& s : r.samples) {
    out << s.time_s << ',' << 1e3 * s.position_m.x() << ',' << 1e3 * s.position_m.y() << ','
        << 1e3 * s.velocity_m_per_s.x() << ',' << 1e3 * s.velocity_m_per_s.y() << ',' << 1e3 * s.depth_m << ','
        << s.rendered_normal_N << ',' << s.motor_normal_N << ',' << s.brake_normal_N << ',' << s.hand_normal_N << ','
        << s.hand_tangent_N << ',' << s.rendered_tangent_N << ',' << s.friction_target_N << ',' << s.brake_capacity_1_Nm
        << ',' << s.brake_capacity_2_Nm << ',' << s.desired_normal_N << '\n';
  }
}

void PrintMetrics(const hy::ContactMetrics& m, bool json, bool friction, const std::string& label,
                  const std::string& extra_json = "") {
  std::cout << std::setprecision(5);
  if (json) {
    std::cout << "{\"scenario\": \"" << label << "\", \"bounces\": " << m.bounces
              << ", \"big_bounces\": " << m.big_bounces << ", \"largest_bounce_mm\": " << m.largest_bounce_mm
              << ", \"transient_s\": " << m.transient_s << ", \"steady_state_error_mm\": " << m.steady_state_error_mm
              << ", \"peak_force_N\": " << m.peak_force_N << ", \"peak_hand_force_N\": " << m.peak_hand_force_N
              << ", \"max_depth_mm\": " << m.max_depth_mm << ", \"contact_speed_mm_s\": " << m.contact_speed_mm_s
              << ", \"contact_time_s\": " << m.contact_time_s << ", \"brake_energy_J\": " << m.brake_energy_J
              << ", \"motor_energy_J\": " << m.motor_energy_J;
    if (!friction) {
      std::cout << ", \"nominal_speed_mm_s\": " << m.nominal_speed_mm_s
                << ", \"commanded_speed_mm_s\": " << m.commanded_speed_mm_s
                << ", \"velocity_reversals\": " << m.velocity_reversals;
    }
    if (friction) {
      std::cout << ", \"friction_rms_error_N\": " << m.friction_rms_error_N
                << ", \"friction_positive_work_J\": " << m.friction_positive_work_J
                << ", \"normal_force_std_N\": " << m.normal_force_std_N << ", \"slide_mm\": " << m.slide_mm;
    }
    std::cout << extra_json << "}\n";
    return;
  }
  std::cout << label << ":\n  contact at " << m.contact_time_s << " s, " << m.contact_speed_mm_s
            << " mm/s inward (hand's intended speed " << m.commanded_speed_mm_s << " mm/s)\n  bounces " << m.bounces
            << " (" << m.big_bounces << " over 1 mm, largest " << m.largest_bounce_mm << " mm)"
            << "\n  transient " << m.transient_s << " s\n  steady-state error " << m.steady_state_error_mm
            << " mm (max depth " << m.max_depth_mm << " mm)\n  peak force " << m.peak_force_N << " N (hand "
            << m.peak_hand_force_N << " N)\n  brake work " << m.brake_energy_J << " J, motor work " << m.motor_energy_J
            << " J\n";
  if (friction) {
    std::cout << "  friction: rms error " << m.friction_rms_error_N << " N, positive work "
              << m.friction_positive_work_J << " J, normal force std " << m.normal_force_std_N << " N, slide "
              << m.slide_mm << " mm\n";
  }
}

/// depth_range_mm: the depth axis of a wall plot (lower, upper); the approach is cut off so that a bounce of a
/// fraction of a millimetre shows (empty for the friction plot). time_range_s: the time axis of a wall plot's time
/// panels (empty: the whole run), so that the contact is not a sliver of the run.
void PlotContact(const std::string& prefix, const std::string& title, bool friction,
                 std::pair<double, double> depth_range_mm = {0.0, 0.0},
                 std::pair<double, double> time_range_s = {0.0, 0.0}) {
  const std::string csv = prefix + ".csv";
  std::ostringstream gp;
  // Each panel's key sits below its axes (the bottom margin is set so that gnuplot does not draw the key over the
  // x label), the y ranges are autoscaled to every curve, and curves that share a panel have distinct colours.
  gp << "set terminal png size 1200,900\nset output '" << prefix << ".png'\nset datafile separator ','\n"
     << "set multiplot layout 2,2 title '" << title << "' noenhanced\nset grid\nset xlabel 't (s)'\n"
     << "set key outside below horizontal\nset bmargin 6\n";
  if (friction) {
    gp << "set ylabel 'position (mm)'\nset title 'position'\nplot '" << csv
       << "' skip 1 using 1:2 w l lc rgb '#9400d3' t 'x (along surface)', '" << csv
       << "' skip 1 using 1:6 w l lc rgb '#009e73' t 'depth'\n"
       << "set ylabel 'velocity (mm/s)'\nset title 'velocity'\nplot '" << csv
       << "' skip 1 using 1:4 w l lc rgb '#9400d3' t 'v_x'\n"
       << "set ylabel 'force (N)'\nset title 'forces'\nplot '" << csv
       << "' skip 1 using 1:10 w l lc rgb '#9400d3' t 'hand normal', '" << csv
       << "' skip 1 using 1:11 w l lc rgb '#009e73' t 'hand tangential', '" << csv
       << "' skip 1 using 1:($4>0?$12:-$12) w l lc rgb '#e51e10' t 'friction shown', '" << csv
       << "' skip 1 using 1:13 w l dt 2 lc rgb 'black' t 'mu F_N'\n"
       << "set xlabel 'hand tangential force (N)'\nset ylabel 'friction shown (N)'\nset title 'friction vs "
       << "external force (Fig. 10(b))'\nplot '" << csv << "' skip 1 using 11:12 w l lc rgb '#9400d3' notitle\n"
       << "unset multiplot\n";
  } else {
    const bool ranged = depth_range_mm.second > depth_range_mm.first;
    std::ostringstream range;
    range << "[" << depth_range_mm.first << ":" << depth_range_mm.second << "]";
    // The depth axis spans the contact, so a sub-millimetre bounce shows; the approach is off it, as the title says.
    if (ranged) gp << "set yrange " << range.str() << "\n";
    // The time panels show the contact and its settling (the x label says which part of the run that is).
    const bool timed = time_range_s.second > time_range_s.first;
    std::ostringstream time_axis;
    if (timed) {
      time_axis << std::fixed << std::setprecision(2) << "set xrange [" << time_range_s.first << ":"
                << time_range_s.second << "]\nset xlabel 't (s): " << time_range_s.first << " to "
                << time_range_s.second << " s of the run'\n";
    }
    const std::string time_clip =
        timed ? "# ranges: x clipped (the time axis shows the contact, as its label says)\n" : std::string();
    gp << time_axis.str();
    if (ranged || timed) {
      gp << "# ranges: " << (timed ? "x" : "") << (ranged ? "y" : "")
         << " clipped (the approach is off the depth axis; the time axis shows the contact)\n";
    }
    gp << "set ylabel 'depth (mm)'\nset title 'position (depth into the wall; the approach is off the axis)'\nplot '"
       << csv << "' skip 1 using 1:6 w l lc rgb '#9400d3' t 'depth', 0 w l dt 2 lc rgb 'gray' t 'surface'\n"
       << "set autoscale y\nset ylabel 'velocity (mm/s)'\nset title 'velocity'\n"
       << (timed ? "# ranges: xy clipped (the time axis shows the contact; the approach's speed before it is off "
                   "the axes)\n"
                 : "")
       << "plot '" << csv << "' skip 1 using 1:5 w l lc rgb '#9400d3' t 'v_y'\n";
    gp << "set ylabel 'force (N)'\nset title 'force'\n"
       << time_clip << "plot '" << csv << "' skip 1 using 1:7 w l lw 2 lc rgb '#9400d3' t 'wall (rendered)', '" << csv
       << "' skip 1 using 1:8 w l lc rgb '#0072b2' t 'motors', '" << csv
       << "' skip 1 using 1:9 w l lc rgb '#e51e10' t 'brakes', '" << csv
       << "' skip 1 using 1:10 w l lc rgb '#e69f00' t 'hand'\n"
       << (ranged ? "# ranges: x clipped (the approach is off the depth axis)\nset xrange " + range.str() + "\n"
                  : std::string("set autoscale x\n"))
       << "set xlabel 'depth (mm)'\nset ylabel 'force (N)'\nset title 'force vs position (the approach is off the "
          "axis)'\nplot '"
       << csv << "' skip 1 using 6:7 w l lc rgb '#9400d3' t 'wall (rendered)'\nunset multiplot\n";
  }
  RunGnuplot(prefix + ".gp", gp.str());
}

struct WallOptions {
  std::string model = "hybrid";
  double motor_time_constant_ms = 0.5;
  double brake_time_constant_ms = 50.0;
  double hand_mass_kg = 0.5;
  double brake_model_mismatch = hy::AllocationConfig{}.brake_model_mismatch;
  double speed_mm_s = 250.0;
  bool at_contact_speed = false;
  bool no_brakes = false;
  double hybrid_spring_N_per_mm = 0.0;
  double release_at_s = -1.0;
  double linear_damper_Ns_per_m = hy::WallConfig{}.linear_damper_Ns_per_m;
  std::string output;
  bool json = false;
  bool no_plot = false;
};

/// The wall scenario with the command line's model values (every figure says which it uses).
hy::WallScenarioConfig WallConfigFrom(const WallOptions& o) {
  hy::WallKind kind{};
  if (!hy::ParseWallKind(o.model.c_str(), kind)) throw Error("--model must be spring, popc, hybrid or linear-damper");
  if (!(o.speed_mm_s > 0.0 && o.speed_mm_s <= 3000.0)) throw Error("--speed-mm-s must be in (0, 3000]");
  hy::WallScenarioConfig config = hy::ScenarioForModel(kind, o.speed_mm_s * 1e-3);
  config.rig.motor.time_constant_s = o.motor_time_constant_ms * 1e-3;
  config.rig.brake.time_constant_s = o.brake_time_constant_ms * 1e-3;
  config.allocation.motor = config.rig.motor;
  config.allocation.brake_model_mismatch = o.brake_model_mismatch;
  config.allocation.brake = hy::AllocationBrakeModel(config.rig.brake, o.brake_model_mismatch);
  config.wall.popc.actuator_time_constant_s = config.rig.motor.time_constant_s;
  config.hand_mass_kg = o.hand_mass_kg;
  if (o.no_brakes) config.allocation.use_brakes = false;
  config.wall.hybrid_stiffness_N_per_m = o.hybrid_spring_N_per_mm * 1e3;
  config.hand.release_s = o.release_at_s;
  config.wall.linear_damper_Ns_per_m = o.linear_damper_Ns_per_m;
  if (o.at_contact_speed) hy::CalibrateContactSpeed(config, o.speed_mm_s * 1e-3);
  return config;
}

std::string ModelNote(const WallOptions& o) {
  std::ostringstream s;
  s << "motor torque lag " << o.motor_time_constant_ms << " ms (current loop), brake lag " << o.brake_time_constant_ms
    << " ms, hand mass " << o.hand_mass_kg << " kg" << (o.no_brakes ? ", no brakes" : "");
  if (o.hybrid_spring_N_per_mm > 0.0) s << ", hybrid spring " << o.hybrid_spring_N_per_mm << " N/mm";
  if (o.release_at_s >= 0.0) s << ", hand lets go at " << o.release_at_s << " s";
  return s.str();
}

int RunWall(const WallOptions& o) {
  const hy::WallScenarioConfig config = WallConfigFrom(o);
  const hy::ScenarioResult r = hy::RunWallScenario(config);
  std::ostringstream name;
  name << "hybrid_wall_" << o.model << "_" << o.speed_mm_s;
  const std::string prefix = o.output.empty() ? name.str() : o.output;
  WriteSamples(prefix + ".csv", r);
  std::ostringstream label;
  label << "hybrid-wall " << o.model << " " << o.speed_mm_s << " mm/s" << (o.at_contact_speed ? " at contact" : "");
  if (!o.no_plot) {
    const hy::ContactMetrics& m = r.metrics;
    // From 0.1 s before the contact to its settling (three transients, at least 0.1 s), within the run.
    std::pair<double, double> time_range{0.0, 0.0};
    if (m.contact_time_s >= 0.0) {
      const double end = std::ceil(20.0 * (m.contact_time_s + std::max(0.1, 3.0 * m.transient_s))) / 20.0;
      const double start = std::max(0.0, std::floor(20.0 * (m.contact_time_s - 0.1)) / 20.0);
      if (end < config.duration_s) time_range = {start, end};
    }
    PlotContact(prefix, label.str() + " (" + ModelNote(o) + ")", false,
                {-std::max(1.0, 1.5 * m.largest_bounce_mm), std::max(0.5, 1.2 * m.max_depth_mm)}, time_range);
  }
  if (o.json) {
    std::ostringstream extra;
    extra << ", \"model\": \"" << o.model << "\", \"motor_torque_lag_ms\": " << o.motor_time_constant_ms
          << ", \"brake_lag_ms\": " << o.brake_time_constant_ms << ", \"hand_mass_kg\": " << o.hand_mass_kg
          << ", \"brake_model_mismatch\": " << o.brake_model_mismatch
          << ", \"brakes\": " << (config.allocation.use_brakes ? "true" : "false");
    PrintMetrics(r.metrics, true, false, label.str(), extra.str());
  } else {
    PrintMetrics(r.metrics, false, false, label.str());
    std::cout << "  model: " << ModelNote(o) << "\n";
  }
  return 0;
}

// The tables of docs/hybrid.md: Table 1 / Figs. 8–9 beside the paper, Fig. 7(a), and the sensitivity of the
// steady-state error to the values the paper does not give.
struct TableOptions {
  bool quick = false;
};

const char* PaperSays(hy::WallKind kind, bool strong) {
  switch (kind) {
    case hy::WallKind::kSpring:
      return strong ? "unstable oscillation, big bounces; small error" : "bounces for 0.11 s; very small error";
    case hy::WallKind::kSpringPoPc:
      return strong ? "one big bounce, then stable; small error" : "one bounce; small error";
    case hy::WallKind::kHybrid:
      return strong ? "no bounce; error about 20 mm" : "no bounce; 0.11 s; error 1.2 mm";
    case hy::WallKind::kLinearDamper:
      return "unstable at 20-40 mm/s";
  }
  return "";
}

void TableRow(const std::string& name, const hy::WallScenarioConfig& c, const char* paper) {
  const hy::ContactMetrics m = hy::RunWallScenario(c).metrics;
  std::cout << std::fixed << std::setprecision(1) << "| " << name << " | " << paper << " | "
            << 1e3 * c.hand.speed_m_per_s << " | " << m.contact_speed_mm_s << " | " << m.bounces << " ("
            << m.big_bounces << ") | " << m.largest_bounce_mm << " | " << std::setprecision(3) << m.transient_s << " | "
            << std::setprecision(2) << m.steady_state_error_mm << " | " << std::setprecision(1) << m.max_depth_mm
            << " | " << m.peak_force_N << " | " << std::setprecision(2) << m.motor_energy_J << " |\n";
}

int RunTable(const TableOptions& o) {
  (void)o;
  std::cout
      << "Table 1 / Figs. 8-9 (motor torque lag 0.5 ms, brake lag 50 ms, hand mass 0.5 kg; every run 0.8 s)\n\n"
      << "| model, nominal speed | paper | hand's intended speed (mm/s) | speed at contact (mm/s) | bounces (over 1 "
         "mm) | largest bounce (mm) | transient (s) | steady-state error (mm) | max depth (mm) | peak force (N) | "
         "motor work on the hand (J) |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (double speed : {0.25, 1.5}) {
    for (hy::WallKind kind : {hy::WallKind::kSpring, hy::WallKind::kSpringPoPc, hy::WallKind::kHybrid}) {
      std::ostringstream name;
      name << hy::ToString(kind) << ", " << 1e3 * speed;
      TableRow(name.str(), hy::PaperWallScenario(kind, speed), PaperSays(kind, speed > 1.0));
      hy::WallScenarioConfig at = hy::PaperWallScenario(kind, speed);
      hy::CalibrateContactSpeed(at, speed);
      if (std::abs(1e3 * at.hand.speed_m_per_s - 1e3 * speed) > 5.0) {
        TableRow(name.str() + " at contact", at, PaperSays(kind, speed > 1.0));
      }
    }
  }
  std::cout << "\nSteady-state error (mm) against the values the paper does not give (one changed at a time from "
               "0.5 kg, 0.5 ms, 50 ms; nominal speeds)\n\n| varied | value | spring 250 | popc 250 | hybrid 250 | "
               "spring 1500 | popc 1500 | hybrid 1500 | hybrid 1500 bounces |\n|---|---|---|---|---|---|---|---|---|\n";
  struct Variant {
    const char* what;
    double value;
    double hand_kg, motor_ms, brake_ms;
  };
  const Variant variants[] = {
      {"hand mass (kg)", 0.2, 0.2, 0.5, 50},          {"hand mass (kg)", 0.5, 0.5, 0.5, 50},
      {"hand mass (kg)", 1.0, 1.0, 0.5, 50},          {"motor lag (ms)", 0.1, 0.5, 0.1, 50},
      {"motor lag (ms)", 2.0, 0.5, 2.0, 50},          {"motor lag (ms)", 7.0, 0.5, 7.0, 50},
      {"brake lag (ms)", 30, 0.5, 0.5, 30},           {"brake lag (ms)", 80, 0.5, 0.5, 80},
      {"joint inertia (kg m^2)", 0.01, 0.5, 0.5, 50}, {"joint inertia (kg m^2)", 0.05, 0.5, 0.5, 50}};
  for (const Variant& v : variants) {
    std::cout << "| " << v.what << " | " << std::setprecision(2) << v.value << " |";
    int hybrid_bounces = 0;
    for (double speed : {250.0, 1500.0}) {
      for (const char* model : {"spring", "popc", "hybrid"}) {
        WallOptions w;
        w.model = model;
        w.speed_mm_s = speed;
        w.hand_mass_kg = v.hand_kg;
        w.motor_time_constant_ms = v.motor_ms;
        w.brake_time_constant_ms = v.brake_ms;
        hy::WallScenarioConfig c = WallConfigFrom(w);
        if (std::string(v.what).rfind("joint inertia", 0) == 0) c.rig.joint_inertia_kgm2 = v.value;
        const hy::ContactMetrics m = hy::RunWallScenario(c).metrics;
        std::cout << " " << std::setprecision(2) << m.steady_state_error_mm << " (" << m.bounces << ") |";
        if (std::string(model) == "hybrid" && speed > 1000.0) hybrid_bounces = m.bounces;
      }
    }
    std::cout << " " << hybrid_bounces << " |\n";
  }
  std::cout << "\n(bounces in brackets)\n\nFig. 7(a): damper walls met at a slow speed, 25 N push, 1 s\n\n| damper | "
               "brakes | "
               "speed (mm/s) | speed at contact (mm/s) | velocity reversals in contact | bounces | max depth (mm) "
               "|\n|---|---|---|---|---|---|---|\n";
  for (bool brakes : {false, true}) {
    for (hy::WallKind kind : {hy::WallKind::kLinearDamper, hy::WallKind::kHybrid}) {
      for (double speed : {0.010, 0.020, 0.030, 0.040, 0.060}) {
        const hy::ContactMetrics m = hy::RunWallScenario(hy::PaperDamperScenario(kind, speed, brakes)).metrics;
        std::cout << "| " << (kind == hy::WallKind::kHybrid ? "cubic 1.6e6 v^3" : "linear 2500 v") << " | "
                  << (brakes ? "yes" : "no") << " | " << std::setprecision(0) << 1e3 * speed << " | "
                  << m.contact_speed_mm_s << " | " << m.velocity_reversals << " | " << m.bounces << " | "
                  << std::setprecision(2) << m.max_depth_mm << " |\n";
      }
    }
  }
  return 0;
}

struct FrictionOptions {
  std::string display = "brake";
  double normal_N = 25.0;
  std::string output;
  bool json = false;
  bool no_plot = false;
};

int RunFriction(const FrictionOptions& o) {
  hy::FrictionDisplay display{};
  if (!hy::ParseFrictionDisplay(o.display.c_str(), display)) throw Error("--display must be motor or brake");
  if (!(o.normal_N > 0.0 && o.normal_N <= 80.0)) throw Error("--normal-N must be in (0, 80]");
  const hy::FrictionScenarioConfig config = hy::PaperFrictionScenario(display, o.normal_N);
  const hy::ScenarioResult r = hy::RunFrictionScenario(config);
  std::ostringstream name;
  name << "hybrid_friction_" << o.display << "_" << o.normal_N;
  const std::string prefix = o.output.empty() ? name.str() : o.output;
  WriteSamples(prefix + ".csv", r);
  std::ostringstream label;
  label << "hybrid-friction " << o.display << " " << o.normal_N << " N";
  if (!o.no_plot) PlotContact(prefix, label.str(), true);
  PrintMetrics(r.metrics, o.json, true, label.str());
  return 0;
}

}  // namespace

void AddHybridScenarios(CLI::App& app) {
  static FmeOptions fme;
  auto* f = app.add_subcommand("hybrid-fme", "Force manipulability over the workspace (Kwon & Song §2.2, eqs 1-2)");
  f->add_option("--output", fme.output, "Output prefix: PREFIX.csv, PREFIX.png");
  f->add_option("--grid-step-mm", fme.grid_step_mm, "Grid step (mm)")->check(CLI::Range(0.5, 50.0));
  f->add_flag("--json", fme.json, "One JSON object on stdout");
  f->add_flag("--no-plot", fme.no_plot, "CSV only");
  f->callback([] { RunFme(fme); });

  static WallOptions wall;
  auto* w = app.add_subcommand("hybrid-wall", "Contact with a hard virtual wall (§4, Figs. 8-9, Table 1)");
  w->add_option("--model", wall.model, "spring | popc | hybrid | linear-damper (Fig. 7(a))")
      ->check(CLI::IsMember({"spring", "popc", "hybrid", "linear-damper"}));
  w->add_option("--speed-mm-s", wall.speed_mm_s, "Operator's approach speed (mm/s): 250 weak, 1500 strong");
  w->add_flag("--at-contact-speed", wall.at_contact_speed,
              "Choose the hand's intended speed so that the speed measured at contact is --speed-mm-s");
  w->add_option("--motor-time-constant-ms", wall.motor_time_constant_ms,
                "Motor torque (current-loop) lag (ms; 0.5; the paper's 7 ms is the mechanical time constant)")
      ->check(CLI::Range(0.0, 100.0));
  w->add_option("--brake-time-constant-ms", wall.brake_time_constant_ms, "Brake lag (ms; paper 50)")
      ->check(CLI::Range(0.0, 500.0));
  w->add_option("--hand-mass-kg", wall.hand_mass_kg, "Operator's hand mass on the handle (kg; 0.5)")
      ->check(CLI::Range(0.0, 5.0));
  w->add_option("--brake-model-mismatch", wall.brake_model_mismatch,
                "The allocation's brake model: lag x (1 - m), torque x (1 + m/2), no remanence (0.2; 0 = exact)")
      ->check(CLI::Range(0.0, 0.9));
  w->add_flag("--no-brakes", wall.no_brakes, "Motors only (for the damper walls)");
  w->add_option("--hybrid-spring-N-per-mm", wall.hybrid_spring_N_per_mm,
                "The hybrid wall's spring (Fig. 6(a); N/mm; 0 = damper + brake as Table 1)")
      ->check(CLI::Range(0.0, 1000.0));
  w->add_option("--linear-damper-Ns-per-m", wall.linear_damper_Ns_per_m,
                "The linear damper of --model linear-damper (N s/m; 2500: 100 N at 40 mm/s)")
      ->check(CLI::Range(0.0, 1e5));
  w->add_option("--release-at-s", wall.release_at_s, "The hand lets go at this time (s; -1 = never)")
      ->check(CLI::Range(-1.0, 10.0));
  w->add_option("--output", wall.output, "Output prefix (default hybrid_wall_<model>_<speed>)");
  w->add_flag("--json", wall.json, "One JSON object on stdout");
  w->add_flag("--no-plot", wall.no_plot, "CSV only");
  w->callback([] { RunWall(wall); });

  static TableOptions table;
  auto* t = app.add_subcommand(
      "hybrid-table", "The tables of docs/hybrid.md: Table 1 / Figs. 8-9 beside the paper, sensitivity, Fig. 7(a)");
  t->callback([] { RunTable(table); });

  static FrictionOptions friction;
  auto* r = app.add_subcommand("hybrid-friction", "Frictional surface displayed by motors or brakes (§5, Figs. 11-12)");
  r->add_option("--display", friction.display, "motor | brake")->check(CLI::IsMember({"motor", "brake"}));
  r->add_option("--normal-N", friction.normal_N, "Operator's push onto the surface (N): 25 small, 40 large");
  r->add_option("--output", friction.output, "Output prefix (default hybrid_friction_<display>_<N>)");
  r->add_flag("--json", friction.json, "One JSON object on stdout");
  r->add_flag("--no-plot", friction.no_plot, "CSV only");
  r->callback([] { RunFriction(friction); });
}

}  // namespace teleop::scenario
