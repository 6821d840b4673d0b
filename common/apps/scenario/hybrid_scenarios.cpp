// Kwon & Song, "Force display using a hybrid haptic device composed of motors and brakes": the FME map (§2.2),
// the wall contact of §4 (Figs. 8, 9, Table 1) and the friction display of §5 (Figs. 11, 12) on the simulated rig.
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

#include "scenarios.hpp"
#include "teleop/device/hybrid/contact_scenarios.hpp"
#include "teleop/device/hybrid/force_manipulability.hpp"
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
    gp << "set terminal png size 1100,520\nset output '" << o.output << ".png'\nset datafile separator ','\n"
       << "set multiplot layout 1,2\nset size ratio -1\nset xlabel 'x (mm)'\nset ylabel 'y (mm)'\n"
       << "set cblabel 'N'\nset xrange [-200:200]\nset yrange [80:330]\n"
       << "set title 'motors: min force in any direction (FME), ellipses 1 N = 0.1 mm' noenhanced\n"
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

void PrintMetrics(const hy::ContactMetrics& m, bool json, bool friction, const std::string& label) {
  std::cout << std::setprecision(5);
  if (json) {
    std::cout << "{\"scenario\": \"" << label << "\", \"bounces\": " << m.bounces
              << ", \"transient_s\": " << m.transient_s << ", \"steady_state_error_mm\": " << m.steady_state_error_mm
              << ", \"peak_force_N\": " << m.peak_force_N << ", \"peak_hand_force_N\": " << m.peak_hand_force_N
              << ", \"max_depth_mm\": " << m.max_depth_mm << ", \"contact_speed_mm_s\": " << m.contact_speed_mm_s
              << ", \"contact_time_s\": " << m.contact_time_s << ", \"brake_energy_J\": " << m.brake_energy_J
              << ", \"motor_energy_J\": " << m.motor_energy_J;
    if (friction) {
      std::cout << ", \"friction_rms_error_N\": " << m.friction_rms_error_N
                << ", \"friction_positive_work_J\": " << m.friction_positive_work_J
                << ", \"normal_force_std_N\": " << m.normal_force_std_N << ", \"slide_mm\": " << m.slide_mm;
    }
    std::cout << "}\n";
    return;
  }
  std::cout << label << ":\n  contact at " << m.contact_time_s << " s, " << m.contact_speed_mm_s
            << " mm/s inward\n  bounces " << m.bounces << "\n  transient " << m.transient_s
            << " s\n  steady-state error " << m.steady_state_error_mm << " mm (max depth " << m.max_depth_mm
            << " mm)\n  peak force " << m.peak_force_N << " N (hand " << m.peak_hand_force_N << " N)\n  brake work "
            << m.brake_energy_J << " J, motor work " << m.motor_energy_J << " J\n";
  if (friction) {
    std::cout << "  friction: rms error " << m.friction_rms_error_N << " N, positive work "
              << m.friction_positive_work_J << " J, normal force std " << m.normal_force_std_N << " N, slide "
              << m.slide_mm << " mm\n";
  }
}

void PlotContact(const std::string& prefix, const std::string& title, bool friction) {
  const std::string csv = prefix + ".csv";
  std::ostringstream gp;
  gp << "set terminal png size 1200,800\nset output '" << prefix << ".png'\nset datafile separator ','\n"
     << "set multiplot layout 2,2 title '" << title << "' noenhanced\nset grid\nset xlabel 't (s)'\n";
  if (friction) {
    gp << "set ylabel 'mm'\nset title 'position'\nplot '" << csv << "' skip 1 using 1:2 w l t 'x (along surface)', '"
       << csv << "' skip 1 using 1:6 w l t 'depth'\n"
       << "set ylabel 'mm/s'\nset title 'velocity'\nplot '" << csv << "' skip 1 using 1:4 w l t 'v_x'\n"
       << "set ylabel 'N'\nset title 'forces'\nplot '" << csv << "' skip 1 using 1:10 w l t 'hand normal', '" << csv
       << "' skip 1 using 1:11 w l t 'hand tangential', '" << csv << "' skip 1 using 1:($4>0?$12:-$12) w l t "
       << "'friction shown', '" << csv << "' skip 1 using 1:13 w l dt 2 t 'mu F_N'\n"
       << "set xlabel 'hand tangential force (N)'\nset ylabel 'friction shown (N)'\nset title 'friction vs "
       << "external force (Fig. 10(b))'\nplot '" << csv << "' skip 1 using 11:12 w l notitle\nunset multiplot\n";
  } else {
    gp << "set ylabel 'mm'\nset title 'position (depth into the wall)'\nplot '" << csv
       << "' skip 1 using 1:6 w l t 'depth', 0 w l dt 2 lc rgb 'gray' t 'surface'\n"
       << "set ylabel 'mm/s'\nset title 'velocity'\nplot '" << csv << "' skip 1 using 1:5 w l t 'v_y'\n"
       << "set ylabel 'N'\nset title 'force'\nplot '" << csv << "' skip 1 using 1:7 w l t 'wall (rendered)', '" << csv
       << "' skip 1 using 1:8 w l t 'motors', '" << csv << "' skip 1 using 1:9 w l t 'brakes', '" << csv
       << "' skip 1 using 1:10 w l t 'hand'\n"
       << "set xlabel 'depth (mm)'\nset ylabel 'N'\nset title 'force vs position'\nplot '" << csv
       << "' skip 1 using 6:7 w l t 'wall (rendered)'\nunset multiplot\n";
  }
  RunGnuplot(prefix + ".gp", gp.str());
}

struct WallOptions {
  std::string model = "hybrid";
  double motor_time_constant_ms = 7.0;
  double speed_mm_s = 250.0;
  std::string output;
  bool json = false;
  bool no_plot = false;
};

int RunWall(const WallOptions& o) {
  hy::WallKind kind{};
  if (!hy::ParseWallKind(o.model.c_str(), kind)) throw Error("--model must be spring, popc or hybrid");
  if (!(o.speed_mm_s > 0.0 && o.speed_mm_s <= 3000.0)) throw Error("--speed-mm-s must be in (0, 3000]");
  hy::WallScenarioConfig config = hy::PaperWallScenario(kind, o.speed_mm_s * 1e-3);
  config.rig.motor.time_constant_s = o.motor_time_constant_ms * 1e-3;
  config.allocation.motor.time_constant_s = config.rig.motor.time_constant_s;
  config.wall.popc.actuator_time_constant_s = config.rig.motor.time_constant_s;
  const hy::ScenarioResult r = hy::RunWallScenario(config);
  std::ostringstream name;
  name << "hybrid_wall_" << o.model << "_" << o.speed_mm_s;
  const std::string prefix = o.output.empty() ? name.str() : o.output;
  WriteSamples(prefix + ".csv", r);
  std::ostringstream label;
  label << "hybrid-wall " << o.model << " " << o.speed_mm_s << " mm/s";
  if (!o.no_plot) PlotContact(prefix, label.str(), false);
  PrintMetrics(r.metrics, o.json, false, label.str());
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
  w->add_option("--model", wall.model, "spring | popc | hybrid")->check(CLI::IsMember({"spring", "popc", "hybrid"}));
  w->add_option("--speed-mm-s", wall.speed_mm_s, "Operator's approach speed (mm/s): 250 weak, 1500 strong");
  w->add_option("--motor-time-constant-ms", wall.motor_time_constant_ms, "Motor torque lag (ms; paper 7)")
      ->check(CLI::Range(0.0, 100.0));
  w->add_option("--output", wall.output, "Output prefix (default hybrid_wall_<model>_<speed>)");
  w->add_flag("--json", wall.json, "One JSON object on stdout");
  w->add_flag("--no-plot", wall.no_plot, "CSV only");
  w->callback([] { RunWall(wall); });

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
