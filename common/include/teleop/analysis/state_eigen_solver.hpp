#pragma once

// Eigen's real eigen solver for the model's state matrix, compiled once, in damping_ratio.cpp, instead of in every
// file that uses it: its fixed-size 8×8 instantiation is the most expensive template code in the tree (tens of
// CPU-seconds per file under ASan + UBSan). Include this, not <Eigen/Eigenvalues>, to use an
// Eigen::EigenSolver<StateMatrix>; the solver is constructed from a StateMatrix (the instantiated compute()).

#include <Eigen/Eigenvalues>

#include "teleop/analysis/discrete_model.hpp"

extern template Eigen::EigenSolver<teleop::analysis::StateMatrix>&
Eigen::EigenSolver<teleop::analysis::StateMatrix>::compute<teleop::analysis::StateMatrix>(
    const Eigen::EigenBase<teleop::analysis::StateMatrix>& matrix, bool computeEigenvectors);
extern template Eigen::EigenSolver<Eigen::MatrixXd>& Eigen::EigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(
    const Eigen::EigenBase<Eigen::MatrixXd>& matrix, bool computeEigenvectors);
