#pragma once

#include <stdexcept>
#include <string>

namespace teleop {

/// The project's one exception type, thrown only at set-up (configuration, opening devices and sockets), never
/// inside the control cycle. The message says what is wrong and what the user can do about it.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace teleop
