#pragma once

#include <cstdint>

namespace teleop::test {

/// Counts heap allocations (operator new / malloc through new) made on this thread while alive
/// (after Drake's limit_malloc). Usage:
///   { AllocationCounter counter; law.Step(in, T); EXPECT_EQ(counter.count(), 0); }
class AllocationCounter {
 public:
  AllocationCounter() noexcept;
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  std::uint64_t count() const noexcept;

 private:
  std::uint64_t start_;
};

}  // namespace teleop::test
