#pragma once

#include <string>

#include "teleop/proto/sample_message.hpp"
#include "teleop/proto/secure_message.hpp"

namespace teleop {

/// The software's version: `git describe` at build time ("0.1.0+g7eafb25-dirty" without a tag, the tag's name with
/// one), or the package version (CMake PROJECT_VERSION) when built outside a git checkout. Every tool's `--version`,
/// the run summary, the DDS state and the session record carry it.
const char* SoftwareVersion() noexcept;

/// What `--version` prints: "<program> <software version>, wire protocol <v1> (psk <v2>)" (docs/protocol.md).
inline std::string VersionText(const std::string& program) {
  return program + " " + SoftwareVersion() + ", wire protocol " + std::to_string(proto::kProtocolVersion) +
         " (authenticated session " + std::to_string(proto::kSecureProtocolVersion) + ")";
}

}  // namespace teleop
