// Operator bounds: the built-in table, the CSV reader and the grids.

#include "teleop/analysis/human_bounds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

TEST(HumanBounds, DefaultGridHas512OperatorsInsideTheBounds) {
  const auto rows = DefaultFingerBounds();
  ASSERT_EQ(rows.size(), 8u);
  EXPECT_DOUBLE_EQ(rows.front().force_N, 2.0);
  EXPECT_DOUBLE_EQ(rows.back().force_N, 20.0);
  const std::vector<HumanModel> humans = MakeHumanGrid(rows, 4);
  ASSERT_EQ(humans.size(), 512u);
  for (const HumanModel& h : humans) {
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const auto& r) { return r.force_N == h.force_N; });
    ASSERT_NE(row, rows.end());
    EXPECT_GE(h.mass_kg, row->mass_min_kg - 1e-15);
    EXPECT_LE(h.mass_kg, row->mass_max_kg + 1e-15);
    EXPECT_GE(h.damping_Ns_per_m, row->damping_min_Ns_per_m - 1e-12);
    EXPECT_LE(h.damping_Ns_per_m, row->damping_max_Ns_per_m + 1e-12);
    EXPECT_GE(h.stiffness_N_per_m, row->stiffness_min_N_per_m - 1e-9);
    EXPECT_LE(h.stiffness_N_per_m, row->stiffness_max_N_per_m + 1e-9);
  }
  // The ends of every range are in the grid (the worst case is usually at a corner).
  EXPECT_TRUE(std::any_of(humans.begin(), humans.end(), [](const HumanModel& h) {
    return h.force_N == 2.0 && h.mass_kg == 0.003 && std::abs(h.damping_Ns_per_m - 0.62) < 1e-12;
  }));
}

TEST(HumanBounds, ParsesCsvWithHeaderAndComments) {
  const std::string text =
      "# my finger\n"
      "force_N, mass_min_kg, mass_max_kg, damping_min_Ns_per_m, damping_max_Ns_per_m, stiffness_min_N_per_m, "
      "stiffness_max_N_per_m\n"
      "2, 0.004, 0.008, 0.6, 2.0, 80, 250   # light touch\n"
      "\n"
      "10, 0.004, 0.008, 1.1, 3.3, 170, 550\n";
  const auto rows = ParseHumanBounds(text, "finger.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_DOUBLE_EQ(rows[1].force_N, 10.0);
  EXPECT_DOUBLE_EQ(rows[1].stiffness_max_N_per_m, 550.0);
  EXPECT_EQ(MakeHumanGrid(rows, 2).size(), 16u);
  EXPECT_EQ(MakeHumanGrid(rows, 1).size(), 2u);
}

TEST(HumanBounds, BadRowsAreRejectedWithFileAndLine) {
  auto message = [](const std::string& text) -> std::string {
    try {
      (void)ParseHumanBounds(text, "b.csv");
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(message("2, 0.004, 0.008, 0.6, 2.0, 80\n").find("b.csv:1: expected 7"), std::string::npos);
  EXPECT_NE(message("\n2, 0.004, 0.008, 0.6, x, 80, 90\n").find("b.csv:2: 'x' is not a number"), std::string::npos);
  EXPECT_NE(message("2, 0.008, 0.004, 0.6, 2.0, 80, 90\n").find("mass_min_kg > mass_max_kg"), std::string::npos);
  EXPECT_NE(message("2, 0, 0.004, 0.6, 2.0, 80, 90\n").find("mass_min_kg must be > 0"), std::string::npos);
  EXPECT_NE(message("2, 0.004, 0.008, -0.6, 2.0, 80, 90\n").find(">= 0"), std::string::npos);
  EXPECT_NE(message("2, 0.004, 0.008, nan, 2.0, 80, 90\n").find("b.csv:1"), std::string::npos);
  EXPECT_NE(message("# nothing\n").find("no bounds rows"), std::string::npos);
  EXPECT_THROW((void)LoadHumanBounds("/nonexistent/bounds.csv"), Error);
}

TEST(HumanBounds, ExplicitListsFormTheFullProduct) {
  const std::vector<double> m{0.003, 0.006}, b{0.5, 1.0, 2.0}, k{100.0};
  const auto humans = MakeHumanGrid(m, b, k);
  EXPECT_EQ(humans.size(), 6u);
  EXPECT_THROW((void)MakeHumanGrid(m, std::vector<double>{}, k), Error);
  EXPECT_THROW((void)MakeHumanGrid(std::vector<double>{-1.0}, b, k), Error);
  EXPECT_THROW((void)MakeHumanGrid(DefaultFingerBounds(), 0), Error);
}

}  // namespace
}  // namespace teleop::analysis

namespace teleop::analysis {
namespace {

TEST(HumanBounds, ShippedExampleFileEqualsTheBuiltInTable) {
  const auto rows = LoadHumanBounds(std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/human_bounds_finger.csv");
  const auto builtin = DefaultFingerBounds();
  ASSERT_EQ(rows.size(), builtin.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_NEAR(rows[i].force_N, builtin[i].force_N, 1e-12);
    EXPECT_NEAR(rows[i].mass_min_kg, builtin[i].mass_min_kg, 1e-12);
    EXPECT_NEAR(rows[i].mass_max_kg, builtin[i].mass_max_kg, 1e-12);
    EXPECT_NEAR(rows[i].damping_min_Ns_per_m, builtin[i].damping_min_Ns_per_m, 1e-9);
    EXPECT_NEAR(rows[i].damping_max_Ns_per_m, builtin[i].damping_max_Ns_per_m, 1e-9);
    EXPECT_NEAR(rows[i].stiffness_min_N_per_m, builtin[i].stiffness_min_N_per_m, 1e-9);
    EXPECT_NEAR(rows[i].stiffness_max_N_per_m, builtin[i].stiffness_max_N_per_m, 1e-9);
  }
}

}  // namespace
}  // namespace teleop::analysis
