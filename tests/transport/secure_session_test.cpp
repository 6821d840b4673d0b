// The authenticated session of protocol version 2 (docs/security.md): key file, handshake, per-frame AEAD, replay
// window, plausibility, rate limiting, counters, and no allocation on the per-datagram path.
#include "teleop/transport/secure_session.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/proto/codec.hpp"
#include "teleop/proto/secure_message.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::transport {
namespace {

namespace fs = std::filesystem;
using proto::SenderRole;
using Bytes = std::vector<std::uint8_t>;
using S = SecureReceiveStatus;

constexpr std::uint64_t kPeriod_ns = 1'000'000;  // 1 kHz

using teleop::test::ScopedTempDir;

void WriteFile(const std::string& path, const std::string& content, mode_t mode) {
  std::ofstream(path) << content;
  ASSERT_EQ(::chmod(path.c_str(), mode), 0);
}

PreSharedKey KeyFromByte(std::uint8_t seed) {
  std::array<std::uint8_t, kPreSharedKeyBytes> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(seed + 7 * i + 1);
  return PreSharedKey(bytes);
}

// A 1-DOF sample at cycle `n`: position creeps at 0.1 m/s, well inside the default plausibility bounds.
proto::SampleMessage Sample(SenderRole sender, std::uint64_t n, int dof = 1) {
  proto::SampleMessage m;
  m.sender = sender;
  m.flags = proto::kFlagEnabled;
  m.dof = static_cast<std::uint8_t>(dof);
  m.sender_time_ns = 1'000'000'000 + n * kPeriod_ns;
  for (int i = 0; i < dof; ++i) {
    m.position_m[i] = 0.01 + 1e-4 * static_cast<double>(n) + 0.01 * i;
    m.velocity_m_per_s[i] = 0.1;
    m.force_N[i] = 1.5 - i;
  }
  return m;
}

SecureSessionConfig Config(SenderRole role, int dof = 1) {
  SecureSessionConfig c;
  c.role = role;
  c.dof = dof;
  return c;
}

// One end with its buffers and its clock.
struct End {
  End(SenderRole role, const PreSharedKey& key, int dof = 1) : session(Config(role, dof), key) {}
  End(const SecureSessionConfig& config, const PreSharedKey& key) : session(config, key) {}

  SecureReceiveResult Feed(const Bytes& datagram) {
    now_ns += 50'000;  // 20 kHz: never rate limited at the default 20000/s
    return session.Receive(datagram, now_ns, reply, received);
  }
  Bytes Reply(const SecureReceiveResult& r) const { return Bytes(reply.begin(), reply.begin() + r.reply_size); }
  Bytes Seal(const proto::SampleMessage& m) {
    std::array<std::uint8_t, proto::kMaxSecureFrameSize> out{};
    const std::size_t n = session.Seal(m, out);
    return Bytes(out.begin(), out.begin() + n);
  }

  SecureSession session;
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> reply{};
  proto::SampleMessage received{};
  std::uint64_t now_ns = 1'000'000'000;
};

Bytes Hello(End& master) {
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> out{};
  const std::size_t n = master.session.BeginHandshake(out);
  return Bytes(out.begin(), out.begin() + n);
}

// Runs the three messages; returns them (hello, welcome, confirm) for replay tests.
std::array<Bytes, 3> Handshake(End& master, End& slave) {
  const Bytes hello = Hello(master);
  const SecureReceiveResult r1 = slave.Feed(hello);
  EXPECT_EQ(r1.status, S::kHandshake);
  const Bytes welcome = slave.Reply(r1);
  const SecureReceiveResult r2 = master.Feed(welcome);
  EXPECT_EQ(r2.status, S::kHandshake);
  const Bytes confirm = master.Reply(r2);
  const SecureReceiveResult r3 = slave.Feed(confirm);
  EXPECT_EQ(r3.status, S::kHandshake);
  return {hello, welcome, confirm};
}

void ExpectBalanced(const SecureCounters& c) {
  const std::uint64_t sum = std::accumulate(c.by_status.begin(), c.by_status.end(), std::uint64_t{0});
  EXPECT_EQ(c.received, sum);
  EXPECT_EQ(c.rejected(), c.received - c.count(S::kSample) - c.count(S::kHandshake));
}

// Only the listed statuses have counts, exactly these.
void ExpectOnly(const SecureCounters& c, std::initializer_list<std::pair<S, std::uint64_t>> expected) {
  for (std::size_t i = 0; i < c.by_status.size(); ++i) {
    const auto s = static_cast<S>(i);
    std::uint64_t want = 0;
    for (const auto& [status, n] : expected) {
      if (status == s) want = n;
    }
    EXPECT_EQ(c.by_status[i], want) << ToString(s);
  }
  ExpectBalanced(c);
}

// ---------------------------------------------------------------------------------------------------------------
// Key file

TEST(SecureKeyFile, LoadsAPrivateHexKey) {
  ScopedTempDir dir("secure");
  const std::string path = dir.File("psk");
  WriteFile(path, "  000102030405060708090a0b0c0d0e0f101112131415161718191A1B1C1D1E1F\n", 0600);
  const PreSharedKey key = LoadPreSharedKey(path);
  for (std::size_t i = 0; i < kPreSharedKeyBytes; ++i) EXPECT_EQ(key.bytes()[i], i);
  ASSERT_EQ(::chmod(path.c_str(), 0400), 0);
  EXPECT_NO_THROW(static_cast<void>(LoadPreSharedKey(path)));
}

TEST(SecureKeyFile, RefusesGroupOrOtherPermissions) {
  ScopedTempDir dir("secure");
  const std::string path = dir.File("psk");
  WriteFile(path, std::string(64, 'a') + "\n", 0600);
  for (const mode_t mode : {0640, 0604, 0644, 0620, 0602, 0610, 0601, 0660}) {
    ASSERT_EQ(::chmod(path.c_str(), mode), 0);
    try {
      static_cast<void>(LoadPreSharedKey(path));
      ADD_FAILURE() << "mode " << std::oct << mode << " accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("chmod 600"), std::string::npos) << what;
      EXPECT_NE(what.find(path), std::string::npos) << what;
    }
  }
}

TEST(SecureKeyFile, RefusesBadContentMissingFilesAndDirectories) {
  ScopedTempDir dir("secure");
  const std::string path = dir.File("psk");
  for (const std::string& content :
       {std::string(63, 'a'), std::string(65, 'a'), std::string(62, 'a') + "zz", std::string(64, '0'),
        std::string(32, 'a') + " " + std::string(32, 'a'), std::string(300, 'a'), std::string()}) {
    fs::remove(path);
    WriteFile(path, content, 0600);
    EXPECT_THROW(static_cast<void>(LoadPreSharedKey(path)), Error) << "'" << content << "'";
  }
  EXPECT_THROW(static_cast<void>(LoadPreSharedKey(dir.File("missing"))), Error);
  fs::create_directory(dir.File("d"));
  ASSERT_EQ(::chmod(dir.File("d").c_str(), 0700), 0);
  EXPECT_THROW(static_cast<void>(LoadPreSharedKey(dir.File("d"))), Error);
}

const std::string kHexKey = "000102030405060708090a0b0c0d0e0f101112131415161718191A1B1C1D1E1F\n";

// Expects LoadPreSharedKey(path) to throw an Error whose message contains every one of `words`.
void ExpectRefused(const std::string& key_file, std::initializer_list<const char*> words) {
  try {
    static_cast<void>(LoadPreSharedKey(key_file));
    ADD_FAILURE() << key_file << " accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const char* w : words) EXPECT_NE(what.find(w), std::string::npos) << what;
  }
}

TEST(SecureKeyFile, RefusesASymbolicLinkEvenToAGoodKey) {
  ScopedTempDir dir("secure");
  const std::string target = dir.File("psk");
  WriteFile(target, kHexKey, 0600);
  const std::string link = dir.File("link");
  ASSERT_EQ(::symlink(target.c_str(), link.c_str()), 0);
  ExpectRefused(link, {"symbolic link", "link"});
  EXPECT_NO_THROW(static_cast<void>(LoadPreSharedKey(target)));
}

TEST(SecureKeyFile, RefusesAFifoWithoutHanging) {
  ScopedTempDir dir("secure");
  const std::string fifo = dir.File("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Without O_NONBLOCK the open would wait for a writer forever; the test would hang, not fail.
  ExpectRefused(fifo, {"not a regular file"});
}

TEST(SecureKeyFile, RefusesAFileOwnedByAnotherUser) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a file to another user";
  ScopedTempDir dir("secure");
  const std::string path = dir.File("psk");
  WriteFile(path, kHexKey, 0600);
  ASSERT_EQ(::chown(path.c_str(), 65534, 65534), 0);  // nobody
  ExpectRefused(path, {"owned by uid 65534", "chown"});
  ExpectRefused(path, {path.c_str()});
}

// systemd credentials (LoadCredential=teleop.key:/etc/teleop/teleop.key): credential:NAME names
// $CREDENTIALS_DIRECTORY/NAME.
class CredentialDirectory : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* old = std::getenv("CREDENTIALS_DIRECTORY");
    if (old != nullptr) saved_ = old;
    had_ = old != nullptr;
  }
  void TearDown() override {
    if (had_) {
      ::setenv("CREDENTIALS_DIRECTORY", saved_.c_str(), 1);
    } else {
      ::unsetenv("CREDENTIALS_DIRECTORY");
    }
  }
  ScopedTempDir dir_{"secure"};
  std::string saved_;
  bool had_ = false;
};

TEST_F(CredentialDirectory, ACredentialIsReadFromTheDirectorySystemdNames) {
  WriteFile(dir_.File("teleop.key"), kHexKey, 0400);
  ASSERT_EQ(::setenv("CREDENTIALS_DIRECTORY", dir_.path().c_str(), 1), 0);
  EXPECT_EQ(ResolveKeyPath("credential:teleop.key"), dir_.File("teleop.key"));
  // The fallback: a config's key_file whose file name is a credential of the unit reads the credential.
  EXPECT_EQ(ResolveKeyPath("/etc/teleop/teleop.key"), dir_.File("teleop.key"));
  EXPECT_EQ(ResolveKeyPath("/etc/teleop/other.key"), "/etc/teleop/other.key") << "no such credential: the path";
  EXPECT_EQ(LoadPreSharedKey("/nonexistent/teleop.key").bytes()[0], 0x00);
  const PreSharedKey key = LoadPreSharedKey("credential:teleop.key");
  EXPECT_EQ(key.bytes()[31], 0x1F);
  // systemd grants the service's user read access by an ACL when it cannot chown: that shows as the group read bit.
  ASSERT_EQ(::chmod(dir_.File("teleop.key").c_str(), 0440), 0);
  EXPECT_NO_THROW(static_cast<void>(LoadPreSharedKey("credential:teleop.key")));
  ASSERT_EQ(::chmod(dir_.File("teleop.key").c_str(), 0444), 0);
  ExpectRefused("credential:teleop.key", {"chmod 600"});
  ExpectRefused("credential:missing.key", {"missing.key", "cannot open"});
  ExpectRefused("credential:../teleop.key", {"one file name"});
  ASSERT_EQ(::chmod(dir_.File("teleop.key").c_str(), 0440), 0);
  ASSERT_EQ(::unsetenv("CREDENTIALS_DIRECTORY"), 0);
  ExpectRefused("credential:teleop.key", {"CREDENTIALS_DIRECTORY", "LoadCredential"});
  ExpectRefused(dir_.File("teleop.key"), {"chmod 600"});  // outside systemd the same file is a plain key: refused
}

TEST(SecureSession, KeepsItsKeysInLockedMemoryExcludedFromCoreDumps) {
  // Counted from /proc/self/smaps: the mappings flagged "dd" (MADV_DONTDUMP) and the locked kB.
  const auto scan = [] {
    std::ifstream in("/proc/self/smaps");
    std::pair<int, long> out{0, 0};
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("VmFlags:", 0) == 0 && (line + " ").find(" dd ") != std::string::npos) ++out.first;
      if (line.rfind("Locked:", 0) == 0) out.second += std::stol(line.substr(7));
    }
    return out;
  };
  const auto before = scan();
  {
    const SecureSession session(Config(SenderRole::kSlave), KeyFromByte(1));
    const auto during = scan();
    EXPECT_GT(during.first, before.first) << "no new MADV_DONTDUMP mapping for the keys";
    // AddressSanitizer's runtime replaces mlock() with a no-op (the sanitizer pass), so nothing is locked there.
#if defined(__SANITIZE_ADDRESS__)
    constexpr bool kMlockWorks = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
    constexpr bool kMlockWorks = false;
#else
    constexpr bool kMlockWorks = true;
#endif
#else
    constexpr bool kMlockWorks = true;
#endif
    if (kMlockWorks) {
      EXPECT_GT(during.second, before.second) << "no new locked memory for the keys";
    }
  }
}

TEST(SecureKeyFile, WritesAFreshPrivateKeyAndNeverOverwrites) {
  ScopedTempDir dir("secure");
  const std::string path = dir.File("psk");
  const mode_t old_mask = ::umask(0);  // the file must still come out 0600
  WriteNewKeyFile(path);
  ::umask(old_mask);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const PreSharedKey a = LoadPreSharedKey(path);
  EXPECT_THROW(WriteNewKeyFile(path), Error);
  const std::string other = dir.File("psk2");
  WriteNewKeyFile(other);
  EXPECT_NE(a.bytes(), LoadPreSharedKey(other).bytes()) << "two fresh keys are equal";
}

// ---------------------------------------------------------------------------------------------------------------
// Handshake

TEST(SecureSession, HandshakeEstablishesTheSameSessionOnBothEnds) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  EXPECT_EQ(master.session.state(), SecureSessionState::kNoSession);
  EXPECT_EQ(master.Seal(Sample(SenderRole::kMaster, 0)).size(), 0u) << "sealed without a session";
  const auto messages = Handshake(master, slave);
  EXPECT_EQ(messages[0].size(), 80u);
  EXPECT_EQ(messages[1].size(), 72u);
  EXPECT_EQ(messages[2].size(), 48u);
  EXPECT_EQ(master.session.state(), SecureSessionState::kEstablished);
  EXPECT_EQ(slave.session.state(), SecureSessionState::kEstablished);
  EXPECT_NE(master.session.session_id(), 0u);
  EXPECT_EQ(master.session.session_id(), slave.session.session_id());

  // Both directions carry samples bit for bit (the inner sequence is the frame's).
  for (std::uint64_t n = 0; n < 5; ++n) {
    const proto::SampleMessage m = Sample(SenderRole::kMaster, n);
    const Bytes frame = master.Seal(m);
    ASSERT_EQ(frame.size(), 28u + 64u + 16u);
    const SecureReceiveResult r = slave.Feed(frame);
    ASSERT_EQ(r.status, S::kSample);
    EXPECT_TRUE(r.newest);
    EXPECT_EQ(slave.received.sequence, n);
    EXPECT_EQ(slave.received.position_m[0], m.position_m[0]);
    EXPECT_EQ(slave.received.force_N[0], m.force_N[0]);
    EXPECT_EQ(slave.received.flags, m.flags);
    EXPECT_EQ(master.Feed(slave.Seal(Sample(SenderRole::kSlave, n))).status, S::kSample);
  }
  ExpectOnly(slave.session.counters(), {{S::kHandshake, 2}, {S::kSample, 5}});
  ExpectOnly(master.session.counters(), {{S::kHandshake, 1}, {S::kSample, 5}});
  EXPECT_EQ(slave.session.counters().sessions_established, 1u);
  EXPECT_EQ(master.session.counters().sessions_established, 1u);

  // The payload is encrypted: the sample's bytes do not appear in the frame.
  std::array<std::uint8_t, 64> plain{};
  ASSERT_EQ(proto::EncodeSample(Sample(SenderRole::kMaster, 5), plain), 64u);
  const Bytes frame = master.Seal(Sample(SenderRole::kMaster, 5));
  EXPECT_EQ(std::search(frame.begin(), frame.end(), plain.begin() + 36, plain.begin() + 44), frame.end());
}

TEST(SecureSession, WrongKeyIsRefusedAtEitherEnd) {
  // The slave holds another key: the hello's MAC fails, no welcome is sent.
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave_b(SenderRole::kSlave, KeyFromByte(2));
  const SecureReceiveResult r = slave_b.Feed(Hello(master));
  EXPECT_EQ(r.status, S::kBadHandshakeTag);
  EXPECT_EQ(r.reply_size, 0u);
  EXPECT_EQ(slave_b.session.state(), SecureSessionState::kNoSession);
  ExpectOnly(slave_b.session.counters(), {{S::kBadHandshakeTag, 1}});

  // A slave with the right key answers; a master with another key refuses that welcome.
  End slave_a(SenderRole::kSlave, KeyFromByte(1));
  End master_b(SenderRole::kMaster, KeyFromByte(2));
  static_cast<void>(Hello(master_b));
  const SecureReceiveResult w = slave_a.Feed(Hello(master));
  ASSERT_EQ(w.status, S::kHandshake);
  EXPECT_EQ(master_b.Feed(slave_a.Reply(w)).status, S::kBadHandshakeTag);
  EXPECT_EQ(master_b.session.state(), SecureSessionState::kHandshaking);
  EXPECT_EQ(master_b.Seal(Sample(SenderRole::kMaster, 0)).size(), 0u);

  // A forged hello (right layout, random tag) is refused the same way.
  Bytes forged = Hello(master);
  forged[50] ^= 0x01;
  EXPECT_EQ(slave_a.Feed(forged).status, S::kBadHandshakeTag);
}

TEST(SecureSession, AWelcomeAnswersOnlyTheHelloItWasMadeFor) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const SecureReceiveResult r = slave.Feed(Hello(master));
  const Bytes old_welcome = slave.Reply(r);
  static_cast<void>(Hello(master));  // retry: a new ephemeral key, the old welcome no longer fits
  EXPECT_EQ(master.Feed(old_welcome).status, S::kBadHandshakeTag);
  // A welcome while no handshake runs is unexpected; a slave never takes a welcome.
  End idle_master(SenderRole::kMaster, KeyFromByte(1));
  EXPECT_EQ(idle_master.Feed(old_welcome).status, S::kUnexpectedHandshake);
  EXPECT_EQ(slave.Feed(old_welcome).status, S::kWrongSender);
}

// ---------------------------------------------------------------------------------------------------------------
// Frames: forged, replayed, reordered, truncated, bit-flipped

class EstablishedPair : public ::testing::Test {
 protected:
  void SetUp() override { Handshake(master_, slave_); }
  std::uint64_t Slave(S s) const { return slave_.session.counters().count(s); }

  End master_{SenderRole::kMaster, KeyFromByte(1)};
  End slave_{SenderRole::kSlave, KeyFromByte(1)};
};

TEST_F(EstablishedPair, ForgedFramesAreRejectedAndDoNotMoveTheWindow) {
  const Bytes genuine = master_.Seal(Sample(SenderRole::kMaster, 0));
  // A forger knows the layout and the session id (sent in clear), not the key.
  Bytes forged = genuine;
  for (std::size_t i = 28; i < forged.size(); ++i) forged[i] = static_cast<std::uint8_t>(i * 31);
  EXPECT_EQ(slave_.Feed(forged).status, S::kBadTag);
  // Huge sequence jumps: far ahead, the largest, and the next one.
  for (const std::uint64_t seq : {std::uint64_t{1} << 40, ~std::uint64_t{0}, std::uint64_t{1}}) {
    Bytes jump = genuine;
    for (int b = 0; b < 8; ++b) jump.at(16 + b) = static_cast<std::uint8_t>(seq >> (8 * b));
    EXPECT_EQ(slave_.Feed(jump).status, S::kBadTag) << seq;
  }
  // The genuine frame and its successors still go through: nothing forged marked the window.
  EXPECT_EQ(slave_.Feed(genuine).status, S::kSample);
  for (std::uint64_t n = 1; n < 4; ++n) {
    const SecureReceiveResult r = slave_.Feed(master_.Seal(Sample(SenderRole::kMaster, n)));
    EXPECT_EQ(r.status, S::kSample);
    EXPECT_TRUE(r.newest);
  }
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2}, {S::kBadTag, 4}, {S::kSample, 4}});
}

TEST_F(EstablishedPair, ReplaysAreRejectedAtOnceAndAfterAnyDelay) {
  std::vector<Bytes> captured;
  for (std::uint64_t n = 0; n < 20; ++n) {
    captured.push_back(master_.Seal(Sample(SenderRole::kMaster, n)));
    ASSERT_EQ(slave_.Feed(captured.back()).status, S::kSample);
  }
  EXPECT_EQ(slave_.Feed(captured.back()).status, S::kReplayed);  // live duplicate
  for (std::size_t i = 0; i < captured.size(); ++i) EXPECT_EQ(slave_.Feed(captured[i]).status, S::kReplayed);
  // Seconds later (the window moved on by 300 frames): every old frame is behind the window.
  for (std::uint64_t n = 20; n < 320; ++n) {
    ASSERT_EQ(slave_.Feed(master_.Seal(Sample(SenderRole::kMaster, n))).status, S::kSample);
  }
  for (const Bytes& old : captured) EXPECT_EQ(slave_.Feed(old).status, S::kTooOld);
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2}, {S::kSample, 320}, {S::kReplayed, 21}, {S::kTooOld, 20}});
}

TEST_F(EstablishedPair, ReorderingWithinTheWindowIsAcceptedOnceBeyondItRefused) {
  std::vector<Bytes> frames;
  for (std::uint64_t n = 0; n < 300; ++n) frames.push_back(master_.Seal(Sample(SenderRole::kMaster, n)));
  const SecureReceiveResult newest = slave_.Feed(frames[299]);
  ASSERT_EQ(newest.status, S::kSample);
  EXPECT_TRUE(newest.newest);
  // 299 - 43 = 256 is outside a 256-frame window, 299 - 44 = 255 inside.
  EXPECT_EQ(slave_.Feed(frames[0]).status, S::kTooOld);
  EXPECT_EQ(slave_.Feed(frames[43]).status, S::kTooOld);
  const SecureReceiveResult late = slave_.Feed(frames[44]);
  EXPECT_EQ(late.status, S::kSample);
  EXPECT_FALSE(late.newest) << "a late frame is authentic but not the newest";
  EXPECT_EQ(slave_.Feed(frames[44]).status, S::kReplayed);
  EXPECT_EQ(slave_.Feed(frames[298]).status, S::kSample);
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2}, {S::kSample, 3}, {S::kTooOld, 2}, {S::kReplayed, 1}});
}

TEST(SecureSession, TruncatedFramesAreRejected) {
  End master(SenderRole::kMaster, KeyFromByte(1), 2);
  End slave(SenderRole::kSlave, KeyFromByte(1), 2);
  Handshake(master, slave);
  const Bytes frame = master.Seal(Sample(SenderRole::kMaster, 0, 2));
  ASSERT_EQ(frame.size(), 28u + 88u + 16u);
  // Cut anywhere: the size no longer matches the length field.
  for (std::size_t n = 0; n < frame.size(); ++n) {
    EXPECT_EQ(slave.Feed(Bytes(frame.begin(), frame.begin() + n)).status, S::kMalformed) << n;
  }
  // Cut one DOF out and fix the length field so that the layout is consistent: the tag catches it.
  Bytes cut(frame.begin(), frame.begin() + 28 + 64);
  cut.insert(cut.end(), frame.end() - 16, frame.end());
  cut[24] = 64;
  cut[25] = 0;
  EXPECT_EQ(slave.Feed(cut).status, S::kBadTag);
  // Extra bytes are refused too.
  Bytes longer = frame;
  longer.push_back(0);
  EXPECT_EQ(slave.Feed(longer).status, S::kMalformed);
  EXPECT_EQ(slave.Feed(frame).status, S::kSample);
  ExpectOnly(slave.session.counters(),
             {{S::kHandshake, 2}, {S::kMalformed, frame.size() + 1}, {S::kBadTag, 1}, {S::kSample, 1}});
}

TEST_F(EstablishedPair, EveryBitFlipIsRejectedUnderAKnownReason) {
  const Bytes frame = master_.Seal(Sample(SenderRole::kMaster, 0));
  ASSERT_EQ(frame.size(), 108u);
  for (std::size_t bit = 0; bit < frame.size() * 8; ++bit) {
    Bytes flipped = frame;
    flipped[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    const SecureReceiveResult r = slave_.Feed(flipped);
    EXPECT_NE(r.status, S::kSample) << "bit " << bit;
  }
  // Where each flip lands (docs/protocol.md): magic, version, type, reserved bytes and the length field make the
  // frame malformed; the sender byte's bit 0 makes it our own role, its other bits an invalid role; the session id
  // names another session; the sequence, ciphertext and tag fail the AEAD.
  const std::uint64_t malformed = 32 + 8 + 8 + 7 + 8 + 16 + 16;
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2},
                                         {S::kMalformed, malformed},
                                         {S::kWrongSender, 1},
                                         {S::kWrongSession, 64},
                                         {S::kBadTag, 64 + 64 * 8 + 16 * 8}});
  EXPECT_EQ(slave_.Feed(frame).status, S::kSample) << "the genuine frame is still fresh";
}

TEST_F(EstablishedPair, ForgedShutdownAndFaultFlagsAreIgnoredAndCounted) {
  // 1. An unauthenticated version-1 sample with the shutdown flag, as an attacker on the host sends it.
  proto::SampleMessage shutdown = Sample(SenderRole::kMaster, 0);
  shutdown.flags = proto::kFlagShutdown;
  std::array<std::uint8_t, 64> v1{};
  ASSERT_EQ(proto::EncodeSample(shutdown, v1), 64u);
  EXPECT_EQ(slave_.Feed(Bytes(v1.begin(), v1.end())).status, S::kInsecure);
  // 2. A genuine frame with the flags byte flipped in the ciphertext (stream cipher: a flip lands on the flag).
  const Bytes genuine = master_.Seal(Sample(SenderRole::kMaster, 0));
  for (const std::uint8_t flag : {proto::kFlagShutdown, proto::kFlagFault, proto::kFlagPeerLost}) {
    Bytes forged = genuine;
    forged.at(28 + proto::wire::kFlagsOffset) ^= flag;
    EXPECT_EQ(slave_.Feed(forged).status, S::kBadTag);
  }
  // 3. A frame sealed by the real master with the flag set is accepted, flag intact.
  EXPECT_EQ(slave_.Feed(genuine).status, S::kSample);
  const SecureReceiveResult r = slave_.Feed(master_.Seal(shutdown));
  ASSERT_EQ(r.status, S::kSample);
  EXPECT_EQ(slave_.received.flags, proto::kFlagShutdown);
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2}, {S::kInsecure, 1}, {S::kBadTag, 3}, {S::kSample, 2}});
}

// ---------------------------------------------------------------------------------------------------------------
// Session lifetime

TEST(SecureSession, ARestartNeedsANewHandshakeNeverASequenceJump) {
  const PreSharedKey key = KeyFromByte(1);
  End master(SenderRole::kMaster, key);
  End slave(SenderRole::kSlave, key);
  Handshake(master, slave);
  const std::uint64_t first_id = slave.session.session_id();
  std::vector<Bytes> old_frames;
  for (std::uint64_t n = 0; n < 10; ++n) {
    old_frames.push_back(master.Seal(Sample(SenderRole::kMaster, n)));
    ASSERT_EQ(slave.Feed(old_frames.back()).status, S::kSample);
  }
  // The master process restarts: a new object with the same key has no session and cannot send.
  End restarted(SenderRole::kMaster, key);
  EXPECT_EQ(restarted.Seal(Sample(SenderRole::kMaster, 0)).size(), 0u);
  Handshake(restarted, slave);
  EXPECT_NE(slave.session.session_id(), first_id);
  EXPECT_EQ(slave.session.session_id(), restarted.session.session_id());
  // Its sequence starts again at 0 and is accepted, in the new session only.
  EXPECT_EQ(slave.Feed(restarted.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  // The old session's frames (replayed, or from the old process) are refused wholesale.
  for (const Bytes& f : old_frames) EXPECT_EQ(slave.Feed(f).status, S::kWrongSession);
  EXPECT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 10))).status, S::kWrongSession);

  // The slave process restarts: the master's frames find no session until the master shakes hands again.
  End slave2(SenderRole::kSlave, key);
  EXPECT_EQ(slave2.Feed(restarted.Seal(Sample(SenderRole::kMaster, 1))).status, S::kNoSession);
  Handshake(restarted, slave2);
  EXPECT_EQ(slave2.Feed(restarted.Seal(Sample(SenderRole::kMaster, 2))).status, S::kSample);
  ExpectOnly(slave2.session.counters(), {{S::kNoSession, 1}, {S::kHandshake, 2}, {S::kSample, 1}});
}

TEST_F(EstablishedPair, AReplayedHelloDoesNotDisturbTheRunningSession) {
  End other_master(SenderRole::kMaster, KeyFromByte(1));
  const Bytes hello = Hello(other_master);
  ASSERT_EQ(slave_.Feed(hello).status, S::kHandshake);  // answered (the slave cannot tell a replay)...
  // ...but nobody confirms, and the running session carries on.
  EXPECT_EQ(slave_.session.state(), SecureSessionState::kEstablished);
  const std::uint64_t id = slave_.session.session_id();
  EXPECT_EQ(slave_.Feed(master_.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  EXPECT_EQ(slave_.session.session_id(), id);
  // A replayed confirm of the running session is taken as a copy and changes nothing; one of an older session is
  // not awaited.
  const std::uint64_t before = slave_.session.counters().sessions_established;
  const auto messages = Handshake(master_, slave_);
  const std::uint64_t id2 = slave_.session.session_id();
  EXPECT_EQ(slave_.Feed(messages[2]).status, S::kHandshake);
  EXPECT_EQ(slave_.session.session_id(), id2);
  EXPECT_EQ(slave_.session.counters().sessions_established, before + 1);
  static_cast<void>(Handshake(master_, slave_));
  EXPECT_EQ(slave_.Feed(messages[2]).status, S::kUnexpectedHandshake);
}

TEST(SecureSession, ALostConfirmIsReplacedByTheFirstFrame) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const SecureReceiveResult w = slave.Feed(Hello(master));
  ASSERT_EQ(master.Feed(slave.Reply(w)).status, S::kHandshake);  // the confirm is lost
  EXPECT_EQ(slave.session.state(), SecureSessionState::kHandshaking);
  EXPECT_EQ(slave.Seal(Sample(SenderRole::kSlave, 0)).size(), 0u) << "a responder sends only once confirmed";
  EXPECT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  EXPECT_EQ(slave.session.state(), SecureSessionState::kEstablished);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id());
  EXPECT_EQ(slave.session.counters().sessions_established, 1u);
}

// ---------------------------------------------------------------------------------------------------------------
// Plausibility and rate limiting

TEST_F(EstablishedPair, ImplausibleSamplesAreRejectedAndCounted) {
  ASSERT_EQ(slave_.Feed(master_.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  proto::SampleMessage fast = Sample(SenderRole::kMaster, 1);
  fast.velocity_m_per_s[0] = 2.5;  // > 2 m/s
  EXPECT_EQ(slave_.Feed(master_.Seal(fast)).status, S::kImplausible);
  proto::SampleMessage strong = Sample(SenderRole::kMaster, 2);
  strong.force_N[0] = -100.5;  // > 100 N
  EXPECT_EQ(slave_.Feed(master_.Seal(strong)).status, S::kImplausible);
  // A 10 mm jump in 3 ms: 2 m/s · 3 ms + 1 mm = 7 mm allowed.
  proto::SampleMessage jump = Sample(SenderRole::kMaster, 3);
  jump.position_m[0] = Sample(SenderRole::kMaster, 0).position_m[0] + 0.010;
  EXPECT_EQ(slave_.Feed(master_.Seal(jump)).status, S::kImplausible);
  proto::SampleMessage step = Sample(SenderRole::kMaster, 4);
  step.position_m[0] = Sample(SenderRole::kMaster, 0).position_m[0] + 0.008;  // 2 m/s · 4 ms + 1 mm = 9 mm
  EXPECT_EQ(slave_.Feed(master_.Seal(step)).status, S::kSample);
  ExpectOnly(slave_.session.counters(), {{S::kHandshake, 2}, {S::kSample, 2}, {S::kImplausible, 3}});
}

TEST(SecureSession, RejectionsBeyondTheBucketAreCountedAsAFlood) {
  SecureSessionConfig config = Config(SenderRole::kSlave);
  config.max_datagrams_per_s = 1000.0;
  config.datagram_burst = 10.0;
  SecureSession slave(config, KeyFromByte(1));
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> reply{};
  proto::SampleMessage out{};
  const Bytes junk(100, 0xAB);
  std::uint64_t now = 5'000'000'000;
  for (int i = 0; i < 25; ++i) static_cast<void>(slave.Receive(junk, now, reply, out));
  ExpectOnly(slave.counters(), {{S::kMalformed, 10}, {S::kRateLimited, 15}});
  now += 5'000'000;  // 5 ms: 5 tokens
  for (int i = 0; i < 8; ++i) static_cast<void>(slave.Receive(junk, now, reply, out));
  ExpectOnly(slave.counters(), {{S::kMalformed, 15}, {S::kRateLimited, 18}});
}

// A stub that says "version 2 hello" in its first 6 bytes: what took the handshake tokens before they were spent
// only after the MAC.
Bytes Stub(proto::SecureMessageType type) {
  return {0x54, 0x4C, 0x4F, 0x50, proto::kSecureProtocolVersion, static_cast<std::uint8_t>(type)};
}

TEST(SecureSession, AStubFloodLeavesTheHandshakeToTheRealPeer) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const Bytes hello_stub = Stub(proto::SecureMessageType::kHello);
  Bytes forged_hello = Hello(master);  // the right layout and a fresh timestamp, a tag without the key
  forged_hello[60] ^= 0x5A;
  // Everything at one instant (no refill): 1000 stubs and 1000 forged hellos, then the real hello.
  SecureReceiveResult r{};
  for (int i = 0; i < 1000; ++i) {
    r = slave.session.Receive(hello_stub, slave.now_ns, slave.reply, slave.received);
    ASSERT_NE(r.status, S::kHandshake);
    r = slave.session.Receive(forged_hello, slave.now_ns, slave.reply, slave.received);
    ASSERT_NE(r.status, S::kHandshake);
  }
  EXPECT_EQ(slave.session.counters().count(S::kHandshakeRateLimited), 0u) << "nothing unauthentic spent a token";
  const Bytes hello = Hello(master);
  r = slave.session.Receive(hello, slave.now_ns, slave.reply, slave.received);
  ASSERT_EQ(r.status, S::kHandshake);
  const Bytes welcome = slave.Reply(r);
  // The master's side: welcome stubs and forged welcomes first, then the real one.
  Bytes forged_welcome = welcome;
  forged_welcome.at(50) ^= 0x01;
  for (int i = 0; i < 1000; ++i) {
    ASSERT_NE(
        master.session.Receive(Stub(proto::SecureMessageType::kWelcome), master.now_ns, master.reply, master.received)
            .status,
        S::kHandshake);
    ASSERT_NE(master.session.Receive(forged_welcome, master.now_ns, master.reply, master.received).status,
              S::kHandshake);
  }
  r = master.session.Receive(welcome, master.now_ns, master.reply, master.received);
  ASSERT_EQ(r.status, S::kHandshake);
  ASSERT_EQ(slave.Feed(master.Reply(r)).status, S::kHandshake);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id());
  EXPECT_NE(slave.session.session_id(), 0u);
  ExpectBalanced(slave.session.counters());
  ExpectBalanced(master.session.counters());
}

TEST(SecureSession, OnlyTheX25519OfAnAuthenticFreshHelloIsRateLimited) {
  SecureSessionConfig config = Config(SenderRole::kSlave);
  config.max_handshakes_per_s = 1.0;
  config.handshake_burst = 2.0;
  End slave(config, KeyFromByte(1));
  End master(SenderRole::kMaster, KeyFromByte(1));
  std::vector<S> statuses;
  std::uint64_t replies_repeated = 0;
  for (int i = 0; i < 4; ++i) {
    const Bytes hello = Hello(master);  // each one fresh and authentic
    statuses.push_back(slave.session.Receive(hello, slave.now_ns, slave.reply, slave.received).status);
    // Its copy is answered from the cache, without X25519 and without a token.
    const auto copy = slave.session.Receive(hello, slave.now_ns, slave.reply, slave.received);
    if (copy.status == S::kHandshake) ++replies_repeated;
  }
  EXPECT_EQ(statuses,
            (std::vector<S>{S::kHandshake, S::kHandshake, S::kHandshakeRateLimited, S::kHandshakeRateLimited}));
  EXPECT_EQ(replies_repeated, 2u) << "the copies of the two answered hellos";
  EXPECT_EQ(slave.session.counters().replies_repeated, 2u);
  EXPECT_EQ(slave.session.counters().handshakes_started, 2u);
}

TEST_F(EstablishedPair, AFloodOfForgedFramesNeverCostsARealFrame) {
  // Each cycle (1 kHz, one timestamp per cycle as the link gives one per poll): 300 forged frames of the running
  // session with fresh, far-ahead sequences (each costs a full AEAD), 300 version-1 datagrams, then the real frame.
  const Bytes genuine = master_.Seal(Sample(SenderRole::kMaster, 0));
  Bytes forged = genuine;
  std::array<std::uint8_t, 64> v1{};
  ASSERT_EQ(proto::EncodeSample(Sample(SenderRole::kMaster, 0), v1), 64u);
  const Bytes insecure(v1.begin(), v1.end());
  std::uint64_t now = 20'000'000'000;
  ASSERT_EQ(slave_.session.Receive(genuine, now, slave_.reply, slave_.received).status, S::kSample);
  int accepted = 0;
  constexpr int kCycles = 50;
  for (int n = 1; n <= kCycles; ++n) {
    now += kPeriod_ns;
    for (int i = 0; i < 300; ++i) {
      const std::uint64_t seq = 1000 + static_cast<std::uint64_t>(n) * 1000 + static_cast<std::uint64_t>(i);
      for (int b = 0; b < 8; ++b) forged[16 + b] = static_cast<std::uint8_t>(seq >> (8 * b));
      static_cast<void>(slave_.session.Receive(forged, now, slave_.reply, slave_.received));
      static_cast<void>(slave_.session.Receive(insecure, now, slave_.reply, slave_.received));
    }
    const Bytes frame = master_.Seal(Sample(SenderRole::kMaster, static_cast<std::uint64_t>(n)));
    const SecureReceiveResult r = slave_.session.Receive(frame, now, slave_.reply, slave_.received);
    accepted += r.status == S::kSample && r.newest ? 1 : 0;
  }
  EXPECT_EQ(accepted, kCycles) << "every real frame got through";
  const SecureCounters& c = slave_.session.counters();
  // The bucket (burst 512 at its first use in cycle 1, then 20 000/s = 20 per cycle) decides only how the
  // rejections are counted; ±1 for the rounding of the fractional refill.
  const std::uint64_t by_reason = c.count(S::kBadTag) + c.count(S::kInsecure);
  EXPECT_NEAR(static_cast<double>(by_reason), 512.0 + 20.0 * (kCycles - 1), 1.0);
  EXPECT_EQ(c.count(S::kRateLimited) + by_reason, 600u * kCycles);
  ExpectBalanced(c);
}

// ---------------------------------------------------------------------------------------------------------------
// An idempotent handshake: duplicated, retransmitted and replayed hellos

TEST(SecureSession, ADuplicatedHelloGetsTheSameWelcomeAndKeepsThePendingSession) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const Bytes hello = Hello(master);
  const SecureReceiveResult first = slave.Feed(hello);
  ASSERT_EQ(first.status, S::kHandshake);
  const Bytes welcome = slave.Reply(first);
  const SecureReceiveResult second = slave.Feed(hello);  // the network duplicated it
  ASSERT_EQ(second.status, S::kHandshake);
  EXPECT_EQ(slave.Reply(second), welcome) << "the same welcome again";
  // The master switches on the first welcome; the copy gets the same confirm again.
  const SecureReceiveResult confirm = master.Feed(welcome);
  ASSERT_EQ(confirm.status, S::kHandshake);
  const SecureReceiveResult again = master.Feed(welcome);
  ASSERT_EQ(again.status, S::kHandshake);
  EXPECT_EQ(master.Reply(again), master.Reply(confirm));
  ASSERT_EQ(slave.Feed(master.Reply(confirm)).status, S::kHandshake);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id()) << "the pending session survived the copy";
  EXPECT_EQ(slave.Feed(master.Reply(again)).status, S::kHandshake) << "the copy of the confirm changes nothing";
  EXPECT_EQ(slave.session.counters().sessions_established, 1u);
  EXPECT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  EXPECT_EQ(master.Feed(slave.Seal(Sample(SenderRole::kSlave, 0))).status, S::kSample);
  // Once the slave's frames arrive, the master no longer answers a copy of the welcome.
  EXPECT_EQ(master.Feed(welcome).status, S::kUnexpectedHandshake);
  EXPECT_EQ(slave.session.counters().sessions_established, 1u);
  EXPECT_EQ(slave.session.counters().handshakes_started, 1u) << "one X25519 answer, one repeat";
  EXPECT_EQ(slave.session.counters().replies_repeated, 1u);
}

TEST(SecureSession, AnOlderHelloIsRefusedAfterANewerOne) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> out{};
  const std::size_t n1 = master.session.BeginHandshake(out, 1'000);
  const Bytes old_hello(out.begin(), out.begin() + n1);
  const std::size_t n2 = master.session.BeginHandshake(out, 2'000);  // the retry
  const Bytes hello(out.begin(), out.begin() + n2);
  const SecureReceiveResult w = slave.Feed(hello);
  ASSERT_EQ(w.status, S::kHandshake);
  // The first hello arrives late (reordered, or replayed): refused, no welcome, the pending session kept.
  const SecureReceiveResult late = slave.Feed(old_hello);
  EXPECT_EQ(late.status, S::kStaleHandshake);
  EXPECT_EQ(late.reply_size, 0u);
  const SecureReceiveResult c = master.Feed(slave.Reply(w));
  ASSERT_EQ(c.status, S::kHandshake);
  ASSERT_EQ(slave.Feed(master.Reply(c)).status, S::kHandshake);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id());
  // Later replays of either: the older one refused, the last one answered with its welcome (nobody confirms it).
  EXPECT_EQ(slave.Feed(old_hello).status, S::kStaleHandshake);
  EXPECT_EQ(slave.Feed(hello).status, S::kHandshake);
  EXPECT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  ExpectOnly(slave.session.counters(), {{S::kHandshake, 3}, {S::kStaleHandshake, 2}, {S::kSample, 1}});
}

TEST(SecureSession, HelloTimestampsGrowEvenWhenTheClockDoesNot) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> out{};
  std::vector<std::uint64_t> stamps;
  for (const std::uint64_t clock : {5'000u, 5'000u, 4'000u, 9'000u}) {
    ASSERT_EQ(master.session.BeginHandshake(out, clock), proto::secure_wire::kHelloSize);
    proto::KeyExchangeMessage hello{};
    ASSERT_EQ(proto::DecodeKeyExchange(std::span(out).first(proto::secure_wire::kHelloSize), hello),
              proto::DecodeStatus::kOk);
    stamps.push_back(hello.timestamp);
  }
  EXPECT_EQ(stamps, (std::vector<std::uint64_t>{5'000, 5'001, 5'002, 9'000}));
  // The timestamp is under the MAC: changed, the hello is refused.
  End slave(SenderRole::kSlave, KeyFromByte(1));
  Bytes hello(out.begin(), out.begin() + proto::secure_wire::kHelloSize);
  hello[proto::secure_wire::kHelloTimestampOffset + 7] ^= 0x01;
  EXPECT_EQ(slave.Feed(hello).status, S::kBadHandshakeTag);
}

TEST(SecureSession, DuplicatedAndReplayedHellosDuringAReHandshake) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const auto first = Handshake(master, slave);
  const std::uint64_t old_id = slave.session.session_id();
  ASSERT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  ASSERT_EQ(master.Feed(slave.Seal(Sample(SenderRole::kSlave, 0))).status, S::kSample);
  // The master re-handshakes (the slave went quiet for a moment); the new hello is duplicated, the old one replayed.
  const Bytes hello = Hello(master);
  const SecureReceiveResult w = slave.Feed(hello);
  ASSERT_EQ(w.status, S::kHandshake);
  EXPECT_EQ(slave.Feed(first[0]).status, S::kStaleHandshake);
  const SecureReceiveResult w2 = slave.Feed(hello);
  ASSERT_EQ(w2.status, S::kHandshake);
  EXPECT_EQ(slave.Reply(w2), slave.Reply(w));
  // The running session carries on meanwhile.
  EXPECT_EQ(slave.session.session_id(), old_id);
  EXPECT_EQ(master.Feed(slave.Seal(Sample(SenderRole::kSlave, 1))).status, S::kSample);
  const SecureReceiveResult c = master.Feed(slave.Reply(w2));
  ASSERT_EQ(c.status, S::kHandshake);
  EXPECT_NE(master.session.session_id(), old_id);
  // The confirm is lost; the master's first frame of the new session promotes the pending one.
  ASSERT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id());
  EXPECT_EQ(slave.session.counters().sessions_established, 2u);
}

// offload_key_exchange: Receive() hands the X25519 to the helper thread and returns at once; Pump() delivers the
// welcome / confirm. Waits are bounded (a guard against a hang, nothing is timed).
Bytes PumpUntilReply(End& end) {
  for (int i = 0; i < 20000; ++i) {
    const std::size_t n = end.session.Pump(end.reply);
    if (n > 0) return Bytes(end.reply.begin(), end.reply.begin() + n);
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  return {};
}

TEST(SecureSession, TheKeyExchangeRunsOnTheHelperThread) {
  SecureSessionConfig mc = Config(SenderRole::kMaster);
  mc.offload_key_exchange = true;
  SecureSessionConfig sc = Config(SenderRole::kSlave);
  sc.offload_key_exchange = true;
  End master(mc, KeyFromByte(1));
  End slave(sc, KeyFromByte(1));
  // The helper makes the master's first key pair ahead of time; let it.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const Bytes hello = Hello(master);
  const SecureReceiveResult r = slave.Feed(hello);
  ASSERT_EQ(r.status, S::kHandshake);
  EXPECT_EQ(r.reply_size, 0u) << "no welcome from Receive: the helper computes it";
  const SecureReceiveResult copy = slave.Feed(hello);  // a duplicate while it runs: no second exchange
  EXPECT_EQ(copy.status, S::kHandshake);
  EXPECT_EQ(copy.reply_size, 0u);
  const Bytes welcome = PumpUntilReply(slave);
  ASSERT_EQ(welcome.size(), proto::secure_wire::kWelcomeSize);
  EXPECT_EQ(slave.session.Pump(slave.reply), 0u) << "one welcome per exchange";
  const SecureReceiveResult again = slave.Feed(hello);  // and afterwards the cached welcome, inline
  ASSERT_EQ(again.status, S::kHandshake);
  EXPECT_EQ(slave.Reply(again), welcome);

  const SecureReceiveResult w = master.Feed(welcome);
  ASSERT_EQ(w.status, S::kHandshake);
  EXPECT_EQ(w.reply_size, 0u);
  EXPECT_EQ(master.session.state(), SecureSessionState::kHandshaking) << "switches only when the helper is done";
  const Bytes confirm = PumpUntilReply(master);
  ASSERT_EQ(confirm.size(), proto::secure_wire::kConfirmSize);
  ASSERT_EQ(slave.Feed(confirm).status, S::kHandshake);
  EXPECT_NE(master.session.session_id(), 0u);
  EXPECT_EQ(master.session.session_id(), slave.session.session_id());
  EXPECT_EQ(slave.Feed(master.Seal(Sample(SenderRole::kMaster, 0))).status, S::kSample);
  EXPECT_EQ(master.Feed(slave.Seal(Sample(SenderRole::kSlave, 0))).status, S::kSample);
  EXPECT_EQ(slave.session.counters().key_exchanges_offloaded, 1u);
  EXPECT_EQ(master.session.counters().key_exchanges_offloaded, 1u);
  ExpectBalanced(slave.session.counters());
}

TEST(SecureSession, ANewerHelloDuringAnOffloadedExchangeIsAnsweredInstead) {
  // A slave that stalled finds two hellos queued (the master retried): only the newest gets a welcome.
  SecureSessionConfig sc = Config(SenderRole::kSlave);
  sc.offload_key_exchange = true;
  End slave(sc, KeyFromByte(1));
  End master(SenderRole::kMaster, KeyFromByte(1));
  const Bytes first = Hello(master);
  const Bytes second = Hello(master);
  ASSERT_EQ(slave.Feed(first).status, S::kHandshake);
  ASSERT_EQ(slave.Feed(second).status, S::kHandshake);
  EXPECT_EQ(slave.Feed(second).reply_size, 0u) << "a copy of the queued hello is not queued twice";
  EXPECT_EQ(slave.Feed(first).reply_size, 0u) << "a copy of the hello in flight starts nothing";
  const Bytes welcome = PumpUntilReply(slave);
  EXPECT_EQ(slave.Feed(first).status, S::kStaleHandshake) << "once superseded, the older one is a replay";
  ASSERT_EQ(welcome.size(), proto::secure_wire::kWelcomeSize);
  const SecureReceiveResult c = master.Feed(welcome);
  ASSERT_EQ(c.status, S::kHandshake) << "the welcome answers the newest hello";
  ASSERT_EQ(slave.Feed(master.Reply(c)).status, S::kHandshake);
  EXPECT_EQ(slave.session.session_id(), master.session.session_id());
  EXPECT_EQ(slave.session.counters().key_exchanges_offloaded, 2u);
  EXPECT_EQ(slave.session.counters().handshakes_started, 1u) << "one welcome sent";
}

// UdpLink sends a hello only when HelloReady(): with offload that means the helper made the key pair and
// BeginHandshake does no X25519 (key_pairs_inline stays 0); without offload it always computes inline.
TEST(SecureSession, HelloReadyMeansTheHelloCostsNoKeyExchange) {
  SecureSessionConfig mc = Config(SenderRole::kMaster);
  mc.offload_key_exchange = true;
  End master(mc, KeyFromByte(1));
  for (int hello = 0; hello < 3; ++hello) {
    for (int i = 0; i < 1000 && !master.session.HelloReady(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_TRUE(master.session.HelloReady()) << "the helper makes the next key pair";
    ASSERT_EQ(Hello(master).size(), proto::secure_wire::kHelloSize);
  }
  EXPECT_EQ(master.session.counters().key_pairs_inline, 0u);
  EXPECT_EQ(master.session.counters().handshakes_started, 3u);

  End inline_master(SenderRole::kMaster, KeyFromByte(1));
  EXPECT_TRUE(inline_master.session.HelloReady());
  static_cast<void>(Hello(inline_master));
  EXPECT_EQ(inline_master.session.counters().key_pairs_inline, 1u);
}

TEST(SecureSession, AnOffloadedExchangeForAnOlderHelloIsDropped) {
  SecureSessionConfig mc = Config(SenderRole::kMaster);
  mc.offload_key_exchange = true;
  End master(mc, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  const SecureReceiveResult w = slave.Feed(Hello(master));
  ASSERT_EQ(master.Feed(slave.Reply(w)).status, S::kHandshake);  // handed over...
  static_cast<void>(Hello(master));                              // ...and the master retries before the helper is done
  for (int i = 0; i < 200 && master.session.counters().key_exchanges_offloaded == 0; ++i) {
    static_cast<void>(master.session.Pump(master.reply));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(master.session.Pump(master.reply), 0u) << "the result for the older hello is not installed";
  EXPECT_EQ(master.session.state(), SecureSessionState::kHandshaking);
}

TEST(SecureSession, AHelloOfTheRetiredTypeIsMalformed) {
  End master(SenderRole::kMaster, KeyFromByte(1));
  End slave(SenderRole::kSlave, KeyFromByte(1));
  Bytes old = Hello(master);
  old.resize(72);
  old[5] = proto::kRetiredHelloType;
  EXPECT_EQ(slave.Feed(old).status, S::kMalformed);
  EXPECT_EQ(slave.session.state(), SecureSessionState::kNoSession);
}

TEST(SecureSession, RejectsInvalidConfigs) {
  const PreSharedKey key = KeyFromByte(1);
  SecureSessionConfig c = Config(SenderRole::kSlave);
  c.dof = 0;
  EXPECT_THROW(SecureSession(c, key), Error);
  c = Config(SenderRole::kSlave);
  c.max_speed_m_per_s = std::nan("");
  EXPECT_THROW(SecureSession(c, key), Error);
  c = Config(SenderRole::kSlave);
  c.datagram_burst = 0.5;
  EXPECT_THROW(SecureSession(c, key), Error);
  EXPECT_THROW(SecureSession(Config(SenderRole::kSlave), PreSharedKey{}), Error) << "all-zero key";
}

// ---------------------------------------------------------------------------------------------------------------
// The two small pieces on their own

TEST(SecureReplayWindow, SlidesAndForgetsExactlyAtItsWidth) {
  SecureReplayWindow w;
  EXPECT_EQ(w.Classify(~std::uint64_t{0}), SecureReplayWindow::Check::kFresh);  // nothing seen yet
  EXPECT_TRUE(w.Mark(1000));
  EXPECT_EQ(w.Classify(1000), SecureReplayWindow::Check::kReplayed);
  EXPECT_EQ(w.Classify(1000 - 255), SecureReplayWindow::Check::kFresh);
  EXPECT_EQ(w.Classify(1000 - 256), SecureReplayWindow::Check::kTooOld);
  EXPECT_FALSE(w.Mark(990));  // late, inside: accepted once
  EXPECT_EQ(w.Classify(990), SecureReplayWindow::Check::kReplayed);
  // Advancing by less than the width keeps the marks still inside, clears the slots it reuses.
  EXPECT_TRUE(w.Mark(1100));
  EXPECT_EQ(w.Classify(990), SecureReplayWindow::Check::kReplayed);
  EXPECT_EQ(w.Classify(1000), SecureReplayWindow::Check::kReplayed);
  EXPECT_EQ(w.Classify(1099), SecureReplayWindow::Check::kFresh);
  EXPECT_EQ(w.Classify(1000 + 256 - 1), SecureReplayWindow::Check::kFresh);
  // A jump of the full width or more forgets everything behind.
  EXPECT_TRUE(w.Mark(1100 + 256));
  EXPECT_EQ(w.Classify(1100), SecureReplayWindow::Check::kTooOld);
  EXPECT_EQ(w.Classify(1101), SecureReplayWindow::Check::kFresh);
  EXPECT_TRUE(w.Mark(~std::uint64_t{0}));
  EXPECT_EQ(w.Classify(~std::uint64_t{0}), SecureReplayWindow::Check::kReplayed);
  EXPECT_EQ(w.newest(), ~std::uint64_t{0});
}

TEST(SecureRateLimiter, RefillsAtItsRateUpToItsBurstAndIgnoresAClockGoingBack) {
  SecureRateLimiter bucket(1000.0, 3.0);  // 1 token per ms
  const std::uint64_t t0 = 7'000'000'000;
  int taken = 0;
  for (int i = 0; i < 10; ++i) taken += bucket.TryTake(t0) ? 1 : 0;
  EXPECT_EQ(taken, 3);
  EXPECT_FALSE(bucket.TryTake(t0 + 999'000));   // 0.999 tokens
  EXPECT_TRUE(bucket.TryTake(t0 + 1'100'000));  // 1.1 tokens
  EXPECT_FALSE(bucket.TryTake(t0 - 5'000'000'000)) << "a clock going back must not add tokens";
  taken = 0;
  for (int i = 0; i < 10; ++i) taken += bucket.TryTake(t0 + 60'000'000'000) ? 1 : 0;
  EXPECT_EQ(taken, 3) << "a long pause refills to the burst, not beyond";
}

// ---------------------------------------------------------------------------------------------------------------
// Real time

TEST_F(EstablishedPair, SealAndReceiveDoNotAllocate) {
  std::array<std::uint8_t, proto::kMaxSecureFrameSize> frame{};
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> reply{};
  proto::SampleMessage out{};
  std::array<std::uint8_t, 64> v1{};
  ASSERT_EQ(proto::EncodeSample(Sample(SenderRole::kMaster, 0), v1), 64u);
  std::uint64_t now = 10'000'000'000;
  std::uint64_t accepted = 0;
  std::uint64_t rejected = 0;
  {
    test::AllocationCounter counter;
    for (std::uint64_t n = 0; n < 1000; ++n) {
      const proto::SampleMessage m = Sample(SenderRole::kMaster, n);
      const std::size_t size = master_.session.Seal(m, frame);
      now += kPeriod_ns;
      const auto bytes = std::span<const std::uint8_t>(frame).first(size);
      accepted += slave_.session.Receive(bytes, now, reply, out).status == S::kSample ? 1 : 0;
      // The rejection paths too: replay, forgery, version 1.
      rejected += slave_.session.Receive(bytes, now, reply, out).status == S::kReplayed ? 1 : 0;
      frame[23] ^= 0x80;  // a forged, far-ahead sequence: the AEAD runs and fails
      rejected += slave_.session.Receive(bytes, now, reply, out).status == S::kBadTag ? 1 : 0;
      rejected += slave_.session.Receive(v1, now, reply, out).status == S::kInsecure ? 1 : 0;
    }
    EXPECT_EQ(counter.count(), 0u) << "the per-datagram path allocated";
  }
  EXPECT_EQ(accepted, 1000u);
  EXPECT_EQ(rejected, 3000u);
}

}  // namespace
}  // namespace teleop::transport
