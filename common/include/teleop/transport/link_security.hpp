#pragma once

#include <cstdint>
#include <string>

#include "teleop/transport/secure_session.hpp"

namespace teleop::transport {

/// How a link protects its datagrams (`link.security.mode`, docs/security.md).
enum class LinkSecurityMode : std::uint8_t {
  kInsecure,  ///< Version-1 datagrams: CRC only, no authentication. Benches and closed buses only.
  kPsk,       ///< Version-2 authenticated session (SecureSession) with a pre-shared key file.
};

/// "insecure" / "psk" (the config's spelling).
constexpr const char* ToString(LinkSecurityMode mode) noexcept {
  return mode == LinkSecurityMode::kPsk ? "psk" : "insecure";
}

/// `link.security`. The process config has no default (a config without it is refused, docs/configuration.md);
/// this struct's default, insecure, is for links built in code (unit tests, benchmarks).
struct LinkSecurityConfig {
  LinkSecurityMode mode = LinkSecurityMode::kInsecure;
  std::string key_file;           ///< kPsk: the pre-shared key file, loaded when the link opens (LoadPreSharedKey).
  SecureSessionConfig session{};  ///< Plausibility bounds and rate limits; the link sets role and dof.
  /// Master: a new hello this often while no session is established, and while the peer is silent.
  double handshake_retry_ms = 100.0;
};

}  // namespace teleop::transport
