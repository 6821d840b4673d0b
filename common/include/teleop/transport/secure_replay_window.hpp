#pragma once

#include <array>
#include <cstdint>

namespace teleop::transport {

/// Sliding replay window on the 64-bit frame sequence of one session (RFC 4303 §3.4.3 style, as IPsec and DTLS).
/// A sequence is fresh when it is newer than the newest marked, or within kWindow behind it and not yet marked.
/// Only authenticated sequences may be marked: the session checks before the AEAD (cheap rejection) and marks after
/// it, so a forged sequence number, however far ahead, never moves the window. Fixed size, no allocation.
class SecureReplayWindow {
 public:
  static constexpr std::uint64_t kWindow = 256;

  enum class Check : std::uint8_t { kFresh, kReplayed, kTooOld };

  [[nodiscard]] Check Classify(std::uint64_t sequence) const noexcept {
    if (!any_ || sequence > newest_) return Check::kFresh;
    if (newest_ - sequence >= kWindow) return Check::kTooOld;
    return Bit(sequence) ? Check::kReplayed : Check::kFresh;
  }

  /// Marks a fresh, authenticated sequence; returns true when it became the newest.
  bool Mark(std::uint64_t sequence) noexcept {
    if (!any_ || sequence > newest_) {
      const std::uint64_t advance = any_ ? sequence - newest_ : kWindow;
      if (advance >= kWindow) {
        bits_.fill(0);
      } else {
        for (std::uint64_t s = newest_ + 1; s != sequence; ++s) Clear(s);
      }
      any_ = true;
      newest_ = sequence;
      Set(sequence);
      return true;
    }
    Set(sequence);
    return false;
  }

  bool any() const noexcept { return any_; }
  std::uint64_t newest() const noexcept { return newest_; }

 private:
  bool Bit(std::uint64_t s) const noexcept { return ((bits_[(s % kWindow) / 64] >> (s % 64)) & 1u) != 0; }
  void Set(std::uint64_t s) noexcept { bits_[(s % kWindow) / 64] |= std::uint64_t{1} << (s % 64); }
  void Clear(std::uint64_t s) noexcept { bits_[(s % kWindow) / 64] &= ~(std::uint64_t{1} << (s % 64)); }

  bool any_ = false;
  std::uint64_t newest_ = 0;
  std::array<std::uint64_t, kWindow / 64> bits_{};
};

}  // namespace teleop::transport
