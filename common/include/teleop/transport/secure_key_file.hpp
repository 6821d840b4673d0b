#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace teleop::transport {

/// Bytes of the pre-shared key (crypto_kdf_KEYBYTES; the session layer static_asserts it).
inline constexpr std::size_t kPreSharedKeyBytes = 32;

/// The pre-shared key both ends of a link hold. Wiped (sodium_memzero) when destroyed. Copyable only explicitly.
class PreSharedKey {
 public:
  PreSharedKey() = default;
  explicit PreSharedKey(const std::array<std::uint8_t, kPreSharedKeyBytes>& bytes) noexcept : bytes_(bytes) {}
  PreSharedKey(const PreSharedKey&) = default;
  PreSharedKey& operator=(const PreSharedKey&) = default;
  ~PreSharedKey();

  const std::array<std::uint8_t, kPreSharedKeyBytes>& bytes() const noexcept { return bytes_; }

 private:
  std::array<std::uint8_t, kPreSharedKeyBytes> bytes_{};
};

/// `credential:NAME` names a systemd credential: the file NAME in $CREDENTIALS_DIRECTORY (a unit with
/// `LoadCredential=NAME:/etc/teleop/teleop.key`; docs/deployment.md).
inline constexpr const char* kCredentialPrefix = "credential:";

/// The file a key_file names: `credential:NAME` → $CREDENTIALS_DIRECTORY/NAME (teleop::Error when the variable is
/// unset or NAME is not one file name). A path → $CREDENTIALS_DIRECTORY/<its file name> when that variable is set
/// and such a credential exists (the documented fallback: a unit's `LoadCredential=teleop.key:/etc/teleop/
/// teleop.key` serves a config that says `key_file: teleop.key`), else the path unchanged.
std::string ResolveKeyPath(const std::string& key_file);

/// Loads a key file (a path, or `credential:NAME`): one line of 64 hexadecimal digits (32 bytes), optional
/// surrounding white space, nothing else. Refused with a teleop::Error naming the file and the fix when: it cannot
/// be opened, its last component is a symbolic link (O_NOFOLLOW), it is not a regular file (a FIFO cannot hang the
/// open: O_NONBLOCK), it is not owned by the effective user (a credential may also be root's), any group or other
/// permission bit is set (mode 0600 or 0400, like an ssh private key: `chmod 600 FILE`; a credential may show the
/// group read bit of systemd's ACL), the content is not exactly 64 hex digits, or the key is all zero. Set-up only
/// (it throws).
PreSharedKey LoadPreSharedKey(const std::string& key_file);

/// Writes a fresh random key (libsodium randombytes) to `path`, created with mode 0600; refuses to overwrite an
/// existing file. For `teleop` key generation and tests. Throws teleop::Error.
void WriteNewKeyFile(const std::string& path);

}  // namespace teleop::transport
