#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>

namespace teleop::runtime {

/// Wait-free newest-wins mailbox between exactly one writer thread and exactly one reader thread (a triple buffer).
///
/// The writer copies a value into its private back slot and swaps that slot with the shared middle slot in one atomic
/// exchange; the reader, when the middle slot holds something it has not seen, swaps it with its private front slot.
/// Neither side ever waits for the other, allocates or locks, so the real-time loop can sit on either end. A value is
/// never torn (each slot is owned by one side while it is copied), and a reader always gets the newest value that was
/// completely written before its Read(); older values that were overwritten before the reader looked are dropped on
/// purpose (newest wins) and show up as `writes() - fresh reads`.
///
/// Which thread is the writer and which the reader is fixed by use: two writers (or two readers) at once are a bug.
template <typename T>
class Mailbox {
  static_assert(std::is_trivially_copyable_v<T>, "values cross threads by copy");

 public:
  Mailbox() noexcept : Mailbox(T{}) {}
  /// All three slots start as `initial`, so a Read() before the first Write() returns it (and reports not fresh).
  explicit Mailbox(const T& initial) noexcept {
    for (Slot& s : slots_) s.value = initial;
  }

  /// Writer side: publishes a copy of `value` as the newest. Wait-free (one copy, one atomic exchange).
  void Write(const T& value) noexcept {
    slots_[back_].value = value;
    const std::uint8_t previous =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = static_cast<std::uint8_t>(previous & kIndexMask);
    writes_.fetch_add(1, std::memory_order_relaxed);
  }

  /// Reader side: copies the newest value into `out` and returns true when it was written since the previous Read()
  /// (false: `out` is the same value as last time, or the initial one). Wait-free.
  bool Read(T& out) noexcept {
    const bool fresh = TakeNewest();
    out = slots_[front_].value;
    return fresh;
  }

  /// Reader side: the newest value without a copy; valid until this reader's next Read()/Latest() call.
  const T& Latest(bool* fresh = nullptr) noexcept {
    const bool is_fresh = TakeNewest();
    if (fresh != nullptr) *fresh = is_fresh;
    return slots_[front_].value;
  }

  /// Number of Write() calls so far (any thread; relaxed, for statistics).
  std::uint64_t writes() const noexcept { return writes_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::uint8_t kIndexMask = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;

  bool TakeNewest() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    const std::uint8_t previous = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = static_cast<std::uint8_t>(previous & kIndexMask);
    return true;
  }

  // One cache line per slot and per side, so the writer filling its slot does not slow the reader down.
  struct alignas(64) Slot {
    T value;
  };
  std::array<Slot, 3> slots_{};
  alignas(64) std::atomic<std::uint8_t> middle_{1};  ///< Index of the shared slot | kFresh when unread.
  alignas(64) std::uint8_t back_ = 0;                ///< Writer's private slot.
  std::atomic<std::uint64_t> writes_{0};
  alignas(64) std::uint8_t front_ = 2;  ///< Reader's private slot.
};

}  // namespace teleop::runtime
