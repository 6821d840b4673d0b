#pragma once

// Private to the loopback backend: the set-up checks its three parts share ("loopback plant: …" messages).

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::loopback_detail {

[[noreturn]] inline void Fail(const std::string& message) { throw Error("loopback plant: " + message); }

inline void RequireFinite(double value, const std::string& name) {
  if (!std::isfinite(value)) Fail(name + " must be finite");
}

inline void RequireNonNegative(double value, const std::string& name) {
  if (!std::isfinite(value) || value < 0.0) Fail(name + " = " + std::to_string(value) + " must be finite and >= 0");
}

}  // namespace teleop::device::loopback_detail
