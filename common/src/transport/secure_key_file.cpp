#include "teleop/transport/secure_key_file.hpp"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

static_assert(kPreSharedKeyBytes == crypto_kdf_KEYBYTES);
// Longest accepted file: 64 hex digits plus generous white space. Anything longer is refused unread.
constexpr std::size_t kMaxKeyFileBytes = 256;

std::string Describe(const std::string& path) { return "key file '" + path + "'"; }

int HexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool IsSpace(char c) noexcept { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Owns a descriptor for the duration of a load.
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

PreSharedKey::~PreSharedKey() { sodium_memzero(bytes_.data(), bytes_.size()); }

namespace {

struct Resolved {
  std::string path;
  bool credential = false;
};

Resolved Resolve(const std::string& key_file) {
  const char* directory = std::getenv("CREDENTIALS_DIRECTORY");
  const bool have_directory = directory != nullptr && *directory != '\0';
  if (key_file.rfind(kCredentialPrefix, 0) == 0) {
    const std::string name = key_file.substr(std::strlen(kCredentialPrefix));
    if (name.empty() || name.find('/') != std::string::npos || name == "." || name == "..") {
      throw Error(Describe(key_file) + ": a credential name is one file name (e.g. credential:teleop.key)");
    }
    if (!have_directory) {
      throw Error(Describe(key_file) +
                  ": $CREDENTIALS_DIRECTORY is not set; systemd sets it for a unit with LoadCredential=" + name +
                  ":/etc/teleop/teleop.key (docs/deployment.md); outside systemd give the key file's path instead");
    }
    return {std::string(directory) + "/" + name, true};
  }
  // The fallback for a path: under systemd, a credential with the path's file name is the key the unit loaded
  // (LoadCredential=teleop.key:/etc/teleop/teleop.key), readable by its DynamicUser where the path is not.
  if (have_directory) {
    const std::size_t slash = key_file.find_last_of('/');
    const std::string name = slash == std::string::npos ? key_file : key_file.substr(slash + 1);
    const std::string candidate = std::string(directory) + "/" + name;
    struct stat st {};
    if (!name.empty() && ::lstat(candidate.c_str(), &st) == 0) return {candidate, true};
  }
  return {key_file, false};
}

}  // namespace

std::string ResolveKeyPath(const std::string& key_file) { return Resolve(key_file).path; }

PreSharedKey LoadPreSharedKey(const std::string& key_file) {
  const Resolved where = Resolve(key_file);
  const bool credential = where.credential;
  const std::string& resolved = where.path;
  const std::string path = credential ? resolved + " (credential for " + key_file + ")" : resolved;
  // Open first, then fstat the open file: the checks apply to the bytes read, not to whatever the path names later.
  // O_NOFOLLOW: a symbolic link in the last component is refused (it could point anywhere); O_NONBLOCK: a FIFO or
  // a device cannot hang the start-up in open() (fstat then refuses it as not a regular file).
  const Fd file{::open(resolved.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NOFOLLOW | O_NONBLOCK)};
  if (file.fd < 0) {
    if (errno == ELOOP) {
      throw Error(Describe(path) + ": is a symbolic link; refused (it could redirect the key); give the file itself");
    }
    throw Error(Describe(path) + ": cannot open: " + std::strerror(errno) + " (create one with `teleop-keygen " +
                resolved + "`, then copy it to the other machine; docs/security.md)");
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) throw Error(Describe(path) + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw Error(Describe(path) + ": not a regular file (a FIFO, device or directory)");
  // Owned by whoever runs the process: another user's key (even a private one) is not ours to trust, and it could be
  // changed under us. A systemd credential may also be root's: systemd writes it as root and grants the service's
  // user read access by an ACL (or chowns it), in a directory only that service can enter.
  const uid_t euid = ::geteuid();
  if (st.st_uid != euid && !(credential && st.st_uid == 0)) {
    throw Error(Describe(path) + ": owned by uid " + std::to_string(st.st_uid) + ", not by this process's user (uid " +
                std::to_string(euid) + "); refused: copy it as that user, or `chown " + std::to_string(euid) + " " +
                resolved + "`");
  }
  // Group and others: no access. For a credential an ACL grant to the service user shows as the group read bit (the
  // ACL mask); only that is tolerated there.
  const mode_t forbidden = credential ? (S_IWGRP | S_IXGRP | S_IRWXO) : (S_IRWXG | S_IRWXO);
  if ((st.st_mode & forbidden) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw Error(Describe(path) + ": permissions " + mode +
                " give group or others access; the pre-shared key must be private to its owner: chmod 600 " + resolved);
  }
  std::array<char, kMaxKeyFileBytes + 1> text{};
  std::size_t size = 0;
  while (size < text.size()) {
    const ssize_t n = ::read(file.fd, text.data() + size, text.size() - size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(Describe(path) + ": cannot read: " + std::strerror(errno));
    }
    if (n == 0) break;
    size += static_cast<std::size_t>(n);
  }
  const auto wipe_text = [&text] { sodium_memzero(text.data(), text.size()); };
  if (size > kMaxKeyFileBytes) {
    wipe_text();
    throw Error(Describe(path) + ": too long; expected one line of 64 hexadecimal digits (32 bytes)");
  }
  std::size_t begin = 0;
  std::size_t end = size;
  while (begin < end && IsSpace(text[begin])) ++begin;
  while (end > begin && IsSpace(text[end - 1])) --end;
  std::array<std::uint8_t, kPreSharedKeyBytes> bytes{};
  bool ok = end - begin == 2 * kPreSharedKeyBytes;
  for (std::size_t i = 0; ok && i < kPreSharedKeyBytes; ++i) {
    const int hi = HexValue(text[begin + 2 * i]);
    const int lo = HexValue(text[begin + 2 * i + 1]);
    ok = hi >= 0 && lo >= 0;
    bytes[i] = static_cast<std::uint8_t>((hi << 4) | (lo & 0xF));
  }
  wipe_text();
  if (!ok) {
    sodium_memzero(bytes.data(), bytes.size());
    throw Error(Describe(path) + ": expected exactly 64 hexadecimal digits (32 bytes) and nothing else");
  }
  if (sodium_is_zero(bytes.data(), bytes.size()) == 1) {
    throw Error(Describe(path) + ": the key is all zero; generate a random one");
  }
  PreSharedKey key(bytes);
  sodium_memzero(bytes.data(), bytes.size());
  return key;
}

void WriteNewKeyFile(const std::string& path) {
  if (sodium_init() < 0) throw Error("libsodium failed to initialise");
  const Fd file{::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, S_IRUSR | S_IWUSR)};
  if (file.fd < 0) throw Error(Describe(path) + ": cannot create: " + std::strerror(errno));
  // O_CREAT applies the umask to the mode; make sure the result is 0600 whatever the umask.
  if (::fchmod(file.fd, S_IRUSR | S_IWUSR) != 0) {
    throw Error(Describe(path) + ": cannot set mode 0600: " + std::strerror(errno));
  }
  std::array<std::uint8_t, kPreSharedKeyBytes> bytes{};
  randombytes_buf(bytes.data(), bytes.size());
  std::array<char, 2 * kPreSharedKeyBytes + 2> hex{};
  sodium_bin2hex(hex.data(), hex.size(), bytes.data(), bytes.size());
  sodium_memzero(bytes.data(), bytes.size());
  hex[2 * kPreSharedKeyBytes] = '\n';
  const std::size_t length = 2 * kPreSharedKeyBytes + 1;
  const ssize_t written = ::write(file.fd, hex.data(), length);
  sodium_memzero(hex.data(), hex.size());
  if (written != static_cast<ssize_t>(length)) throw Error(Describe(path) + ": cannot write the key");
}

}  // namespace teleop::transport
