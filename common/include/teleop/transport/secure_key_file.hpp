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

/// Loads a key file: one line of 64 hexadecimal digits (32 bytes), optional surrounding white space, nothing else.
/// Refused with a teleop::Error naming the file and the fix when: it cannot be opened, it is not a regular file, any
/// group or other permission bit is set (it must be mode 0600 or 0400, like an ssh private key: `chmod 600 FILE`),
/// the content is not exactly 64 hex digits, or the key is all zero. Set-up only (it throws).
PreSharedKey LoadPreSharedKey(const std::string& path);

/// Writes a fresh random key (libsodium randombytes) to `path`, created with mode 0600; refuses to overwrite an
/// existing file. For `teleop` key generation and tests. Throws teleop::Error.
void WriteNewKeyFile(const std::string& path);

}  // namespace teleop::transport
