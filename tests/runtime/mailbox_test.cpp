// The wait-free newest-wins mailbox: single-thread semantics, then two threads hammering it, checking that no value is
// ever torn, that the reader never goes back in time, and that the newest value wins.

#include "teleop/runtime/mailbox.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

namespace teleop::runtime {
namespace {

/// A value a torn copy would show: every word derives from the sequence number.
struct Record {
  std::uint64_t sequence = 0;
  std::array<std::uint64_t, 31> words{};  // 256 bytes: several cache lines, copied non-atomically

  static Record Make(std::uint64_t sequence) {
    Record r;
    r.sequence = sequence;
    for (std::size_t i = 0; i < r.words.size(); ++i) r.words[i] = sequence * 0x9E3779B97F4A7C15ull + i;
    return r;
  }
  bool Consistent() const {
    for (std::size_t i = 0; i < words.size(); ++i) {
      if (words[i] != sequence * 0x9E3779B97F4A7C15ull + i) return false;
    }
    return true;
  }
};

TEST(Mailbox, InitialValueUntilTheFirstWriteThenNewestWins) {
  Mailbox<Record> box(Record::Make(7));
  Record out;
  EXPECT_FALSE(box.Read(out));
  EXPECT_EQ(out.sequence, 7u);
  box.Write(Record::Make(1));
  box.Write(Record::Make(2));
  box.Write(Record::Make(3));
  EXPECT_TRUE(box.Read(out));
  EXPECT_EQ(out.sequence, 3u) << "older unread values are dropped: newest wins";
  EXPECT_TRUE(out.Consistent());
  EXPECT_FALSE(box.Read(out)) << "nothing new";
  EXPECT_EQ(out.sequence, 3u) << "the last value stays readable";
  box.Write(Record::Make(4));
  bool fresh = false;
  EXPECT_EQ(box.Latest(&fresh).sequence, 4u);
  EXPECT_TRUE(fresh);
  EXPECT_EQ(box.Latest(&fresh).sequence, 4u);
  EXPECT_FALSE(fresh);
  EXPECT_EQ(box.writes(), 4u);
}

TEST(Mailbox, TwoThreadsNeverTearAndTheNewestWins) {
  constexpr std::uint64_t kWrites = 2'000'000;  // raise for a longer soak
  Mailbox<Record> box(Record::Make(0));
  std::atomic<bool> writer_done{false};
  std::thread writer([&] {
    for (std::uint64_t s = 1; s <= kWrites; ++s) box.Write(Record::Make(s));
    writer_done.store(true, std::memory_order_release);
  });

  std::uint64_t torn = 0;
  std::uint64_t backwards = 0;
  std::uint64_t fresh_reads = 0;
  std::uint64_t fresh_without_progress = 0;
  std::uint64_t last = 0;
  Record r;
  bool done = false;
  while (!done) {
    done = writer_done.load(std::memory_order_acquire);  // read after this sees the final write
    const bool fresh = box.Read(r);
    if (!r.Consistent()) ++torn;
    if (r.sequence < last) ++backwards;
    if (fresh) {
      ++fresh_reads;
      if (r.sequence == last) ++fresh_without_progress;
    }
    last = r.sequence;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_EQ(fresh_without_progress, 0u) << "a fresh read always brings a newer value";
  EXPECT_EQ(last, kWrites) << "after the writer finished, the reader holds its newest value";
  EXPECT_GT(fresh_reads, 0u);
  EXPECT_LE(fresh_reads, kWrites);
  EXPECT_EQ(box.writes(), kWrites);
  EXPECT_FALSE(box.Read(r));
  EXPECT_EQ(r.sequence, kWrites);
}

TEST(Mailbox, ReaderThatFallsBehindGetsTheNewestNotTheOldest) {
  Mailbox<std::uint64_t> box;
  std::uint64_t out = 99;
  for (std::uint64_t round = 1; round <= 1000; ++round) {
    for (std::uint64_t k = 0; k < round % 7 + 1; ++k) box.Write(round * 100 + k);
    ASSERT_TRUE(box.Read(out));
    ASSERT_EQ(out, round * 100 + round % 7);
  }
}

}  // namespace
}  // namespace teleop::runtime
