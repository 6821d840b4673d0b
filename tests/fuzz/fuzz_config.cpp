// libFuzzer harness: the process config loader (teleop::config::ParseProcessConfig, docs/configuration.md), YAML
// text to ProcessConfig, every section reader and every registered device backend's reader included. Property: any
// input either loads or throws teleop::Error (whose message names the file); nothing else escapes (no
// YAML::Exception, no std::out_of_range, no crash, no UB), and a config that loads has the invariants the processes
// rely on (a role, 1..kMaxDof (12) DOF, a positive finite rate, a known transport). Seeds: the shipped rig configs.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "fuzz_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/types.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const teleop::config::ProcessConfig config = teleop::config::ParseProcessConfig(text, "fuzz.yaml");
    TELEOP_FUZZ_CHECK(config.dof >= 1 && config.dof <= teleop::kMaxDof);
    TELEOP_FUZZ_CHECK(std::isfinite(config.loop.rate_hz) && config.loop.rate_hz > 0.0);
    TELEOP_FUZZ_CHECK(std::isfinite(config.loop.duration_s) && config.loop.duration_s >= 0.0);
    TELEOP_FUZZ_CHECK(config.link.transport == "udp" || config.link.transport == "can" ||
                      config.link.transport == "emulated-can");
  } catch (const teleop::Error& e) {
    TELEOP_FUZZ_CHECK(std::string(e.what()).find("fuzz.yaml") != std::string::npos);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "property violated: an exception other than teleop::Error escaped: %s\n", e.what());
    std::abort();
  }
  return 0;
}
