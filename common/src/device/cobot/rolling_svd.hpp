#pragma once

// Eigen's JacobiSVD of the 2×3 rolling-constraint matrix (RollingConstraints), compiled once, in
// bicycle_kinematics.cpp, instead of in each file that decomposes it (bicycle_kinematics.cpp, bicycle_plant.cpp): a
// fixed-size SVD instantiation costs tens of CPU-seconds per file under ASan + UBSan. Include this, not <Eigen/SVD>.

#include <Eigen/SVD>

extern template class Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>>;
