#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <type_traits>

namespace teleop::runtime {

/// Single-producer single-consumer lock-free ring of trivially copyable records. The real-time thread pushes, a
/// non-real-time thread pops. Capacity is fixed at construction (set-up); TryPush never allocates or blocks and
/// returns false when full (the caller counts the drop: never silent).
template <typename T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "records cross threads by copy");

 public:
  explicit SpscRing(std::size_t capacity) : capacity_(capacity + 1), slots_(new T[capacity + 1]) {}

  [[nodiscard]] bool TryPush(const T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t next = (head + 1) % capacity_;
    if (next == tail_.load(std::memory_order_acquire)) return false;
    slots_[head] = value;
    head_.store(next, std::memory_order_release);
    return true;
  }

  [[nodiscard]] bool TryPop(T& value) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    value = slots_[tail];
    tail_.store((tail + 1) % capacity_, std::memory_order_release);
    return true;
  }

  std::size_t capacity() const noexcept { return capacity_ - 1; }

 private:
  const std::size_t capacity_;
  std::unique_ptr<T[]> slots_;
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
};

}  // namespace teleop::runtime
