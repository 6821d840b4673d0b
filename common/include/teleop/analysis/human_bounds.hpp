#pragma once

#include <span>
#include <string>
#include <vector>

#include "teleop/analysis/teleoperator_model.hpp"

namespace teleop::analysis {

/// The bounding lines of possible operators at one nominal force level (the role of the paper's Fig. 4): every
/// operator with mass, damping and stiffness inside these ranges is considered possible.
struct HumanBoundsRow {
  double force_N = 0.0;
  double mass_min_kg = 0.0;
  double mass_max_kg = 0.0;
  double damping_min_Ns_per_m = 0.0;
  double damping_max_Ns_per_m = 0.0;
  double stiffness_min_N_per_m = 0.0;
  double stiffness_max_N_per_m = 0.0;
};

/// Built-in bounds for the index finger tip, force levels 2..20 N (the range Hajian & Howe 1997 measured).
/// docs/stability.md gives the sources and how the lines were drawn; pass your own with LoadHumanBounds.
std::span<const HumanBoundsRow> DefaultFingerBounds() noexcept;

/// Reads bounds from a CSV file: one row per force level with the seven columns of HumanBoundsRow in that order
/// (force_N, mass_min_kg, mass_max_kg, damping_min_Ns_per_m, damping_max_Ns_per_m, stiffness_min_N_per_m,
/// stiffness_max_N_per_m); '#' starts a comment; an optional header line of those names. Throws teleop::Error
/// with "FILE:LINE: reason" on a malformed row, a negative or non-finite value, min > max or mass ≤ 0.
std::vector<HumanBoundsRow> LoadHumanBounds(const std::string& path);
/// Same, from text; `name` stands in for the file name in messages.
std::vector<HumanBoundsRow> ParseHumanBounds(const std::string& text, const std::string& name);

/// Fig. 5's operator set: at every force level, `steps` values of mass × damping × stiffness evenly spaced between
/// the bounds (ends included; a degenerate range gives one value). Default tables with steps = 4 give 8 × 64 = 512
/// operators, the size of the paper's Fig. 6 clouds. Throws teleop::Error when steps < 1 or rows is empty.
std::vector<HumanModel> MakeHumanGrid(std::span<const HumanBoundsRow> rows, int steps = 4);

/// The full product of explicit lists (the CLI's --human-mass/--human-damping/--human-stiffness). Throws
/// teleop::Error on an empty list or an invalid value.
std::vector<HumanModel> MakeHumanGrid(std::span<const double> masses_kg, std::span<const double> dampings_Ns_per_m,
                                      std::span<const double> stiffnesses_N_per_m);

}  // namespace teleop::analysis
