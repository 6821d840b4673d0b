#include "teleop/analysis/human_bounds.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

// Index finger tip, pushing along the finger (the paper's Fig. 4 role). Force levels 2..20 N, the range of Hajian
// & Howe (1997). Mass roughly constant at a few grams; damping and stiffness rising about linearly with the force
// level, as they report. The lines are a documented approximation of the published ranges (docs/stability.md,
// "Operator bounds"), not a digitization of the paper's Fig. 4; they are wide on purpose (worst case).
//   mass       3.0 .. 9.0 g
//   damping    (0.5 + 0.06·F) .. (1.5 + 0.18·F) N·s/m
//   stiffness  (50 + 12·F) .. (150 + 40·F) N/m
constexpr HumanBoundsRow FingerRow(double f) {
  return HumanBoundsRow{f, 0.003, 0.009, 0.5 + 0.06 * f, 1.5 + 0.18 * f, 50.0 + 12.0 * f, 150.0 + 40.0 * f};
}

constexpr std::array<HumanBoundsRow, 8> kDefaultFingerBounds{FingerRow(2.0),  FingerRow(4.0),  FingerRow(6.0),
                                                             FingerRow(8.0),  FingerRow(11.0), FingerRow(14.0),
                                                             FingerRow(17.0), FingerRow(20.0)};

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return {};
  const auto end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

bool ParseDouble(const std::string& text, double& value) {
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto result = std::from_chars(first, last, value);
  return result.ec == std::errc() && result.ptr == last;
}

void ValidateRow(const HumanBoundsRow& r, const std::string& where) {
  const std::array<double, 7> values{r.force_N,
                                     r.mass_min_kg,
                                     r.mass_max_kg,
                                     r.damping_min_Ns_per_m,
                                     r.damping_max_Ns_per_m,
                                     r.stiffness_min_N_per_m,
                                     r.stiffness_max_N_per_m};
  for (double v : values) {
    if (!std::isfinite(v) || v < 0.0) throw Error(where + ": values must be finite and >= 0");
  }
  if (r.mass_min_kg <= 0.0) throw Error(where + ": mass_min_kg must be > 0 (the operator has mass)");
  if (r.mass_min_kg > r.mass_max_kg) throw Error(where + ": mass_min_kg > mass_max_kg");
  if (r.damping_min_Ns_per_m > r.damping_max_Ns_per_m) {
    throw Error(where + ": damping_min_Ns_per_m > damping_max_Ns_per_m");
  }
  if (r.stiffness_min_N_per_m > r.stiffness_max_N_per_m) {
    throw Error(where + ": stiffness_min_N_per_m > stiffness_max_N_per_m");
  }
}

std::vector<double> Spaced(double lo, double hi, int steps) {
  if (steps == 1 || hi == lo) return {lo};
  std::vector<double> values;
  values.reserve(static_cast<std::size_t>(steps));
  for (int i = 0; i < steps; ++i) values.push_back(lo + (hi - lo) * i / (steps - 1));
  return values;
}

}  // namespace

std::span<const HumanBoundsRow> DefaultFingerBounds() noexcept { return kDefaultFingerBounds; }

std::vector<HumanBoundsRow> ParseHumanBounds(const std::string& text, const std::string& name) {
  std::vector<HumanBoundsRow> rows;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    line = Trim(line);
    if (line.empty()) continue;
    const std::string where = name + ":" + std::to_string(line_number);
    std::vector<std::string> fields;
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) fields.push_back(Trim(cell));
    if (rows.empty() && !fields.empty() && fields[0] == "force_N") continue;  // header
    if (fields.size() != 7) {
      throw Error(where +
                  ": expected 7 comma-separated values (force_N, mass_min_kg, mass_max_kg, "
                  "damping_min_Ns_per_m, damping_max_Ns_per_m, stiffness_min_N_per_m, "
                  "stiffness_max_N_per_m), got " +
                  std::to_string(fields.size()));
    }
    std::array<double, 7> v{};
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!ParseDouble(fields[i], v[i])) throw Error(where + ": '" + fields[i] + "' is not a number");
    }
    const HumanBoundsRow row{v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
    ValidateRow(row, where);
    rows.push_back(row);
  }
  if (rows.empty()) throw Error(name + ": no bounds rows (expected at least one force level)");
  return rows;
}

std::vector<HumanBoundsRow> LoadHumanBounds(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw Error(path + ": cannot open the human bounds file");
  std::ostringstream text;
  text << file.rdbuf();
  return ParseHumanBounds(text.str(), path);
}

std::vector<HumanModel> MakeHumanGrid(std::span<const HumanBoundsRow> rows, int steps) {
  if (steps < 1) throw Error("human grid: steps per parameter must be >= 1, got " + std::to_string(steps));
  if (rows.empty()) throw Error("human grid: no bounds rows");
  std::vector<HumanModel> humans;
  humans.reserve(rows.size() * static_cast<std::size_t>(steps * steps * steps));
  for (const HumanBoundsRow& row : rows) {
    ValidateRow(row, "human bounds at " + std::to_string(row.force_N) + " N");
    for (double m : Spaced(row.mass_min_kg, row.mass_max_kg, steps)) {
      for (double b : Spaced(row.damping_min_Ns_per_m, row.damping_max_Ns_per_m, steps)) {
        for (double k : Spaced(row.stiffness_min_N_per_m, row.stiffness_max_N_per_m, steps)) {
          humans.push_back(HumanModel{m, b, k, row.force_N});
        }
      }
    }
  }
  return humans;
}

std::vector<HumanModel> MakeHumanGrid(std::span<const double> masses_kg, std::span<const double> dampings_Ns_per_m,
                                      std::span<const double> stiffnesses_N_per_m) {
  if (masses_kg.empty() || dampings_Ns_per_m.empty() || stiffnesses_N_per_m.empty()) {
    throw Error("human grid: mass, damping and stiffness lists must each have at least one value");
  }
  std::vector<HumanModel> humans;
  humans.reserve(masses_kg.size() * dampings_Ns_per_m.size() * stiffnesses_N_per_m.size());
  for (double m : masses_kg) {
    for (double b : dampings_Ns_per_m) {
      for (double k : stiffnesses_N_per_m) {
        const HumanModel human{m, b, k, 0.0};
        Validate(human);
        humans.push_back(human);
      }
    }
  }
  return humans;
}

}  // namespace teleop::analysis
