#include "teleop/fieldbus/canopen_timebase.hpp"

#include <chrono>
#include <thread>

namespace teleop::fieldbus {

Timebase Timebase::Steady() {
  Timebase t;
  t.now_ns = [] {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
  };
  t.wait_ns = [](std::uint64_t ns) { std::this_thread::sleep_for(std::chrono::nanoseconds(ns)); };
  return t;
}

}  // namespace teleop::fieldbus
