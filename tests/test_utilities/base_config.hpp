#pragma once

// The smallest valid process config, for tests that change one key at a time: loopback plant, an insecure UDP link
// on 127.0.0.1 (the template ports 47001/47002), 1 kHz, K_p 600 N/m, K_d 2 N·s/m. 15 lines, so a test can name a line
// it appends ("rig.yaml:17:...").

#include <string>

namespace teleop::test {

/// `role` "master" or "slave"; each side's own port and its loopback device (the master's 40 g, the slave's 36 g).
inline std::string BaseConfig(const std::string& role, int dof = 1) {
  const bool master = role == "master";
  return "role: " + role + "\ndof: " + std::to_string(dof) + R"(
rate_hz: 1000
link:
  security: {mode: insecure}
)" +
         (master ? "  bind: \"127.0.0.1:47001\"\n  peer: \"127.0.0.1:47002\"\n"
                 : "  bind: \"127.0.0.1:47002\"\n  peer: \"127.0.0.1:47001\"\n") +
         R"(law:
  kp_N_per_m: 600
  kd_Ns_per_m: 2
device:
  backend: loopback
  loopback:
)" + (master ? "    mass_kg: 0.04\n    damping_Ns_per_m: 0.41\n" : "    mass_kg: 0.036\n    damping_Ns_per_m: 0.49\n");
}

}  // namespace teleop::test
