#pragma once

// Tests of kernel receive timestamps (SO_TIMESTAMPNS) need the kernel to stamp datagrams when they arrive.

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <thread>

namespace teleop::test {

/// Holds a UDP socket with SO_TIMESTAMPNS open and, when constructed, waits (at most about 2 s) until the kernel
/// stamps datagrams on arrival. The kernel turns arrival stamping on for the whole system when the first socket asks
/// for it, but through a work item (net_enable_timestamp). Until that item runs, a datagram is stamped when it is
/// read. With six CPU hogs on 2 cores that took over 2 ms in 6 of 150 runs of a test that made the first such
/// socket; with one such socket already open, 0 of 150 failed. While this object lives, stamping stays on: the
/// kernel turns it off only when the last such socket closes.
class KernelArrivalStamps {
 public:
  KernelArrivalStamps() {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK, 0);
    const int on = 1;
    sockaddr_in self{};
    self.sin_family = AF_INET;
    self.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof self;
    if (fd_ < 0 || ::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0 ||
        ::bind(fd_, reinterpret_cast<const sockaddr*>(&self), sizeof self) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&self), &length) != 0) {
      return;
    }
    for (int attempt = 0; attempt < 1000 && !active_; ++attempt) {
      const char byte = 0;
      if (::sendto(fd_, &byte, 1, 0, reinterpret_cast<const sockaddr*>(&self), sizeof self) != 1) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      const std::int64_t read_at = RealtimeNs();
      const std::int64_t stamp = ReadStamp();
      // Stamped on arrival: at least 1 ms before the read (2 ms after the send).
      active_ = stamp > 0 && stamp < read_at - 1'000'000;
    }
  }
  ~KernelArrivalStamps() {
    if (fd_ >= 0) ::close(fd_);
  }
  KernelArrivalStamps(const KernelArrivalStamps&) = delete;
  KernelArrivalStamps& operator=(const KernelArrivalStamps&) = delete;

  /// True once a datagram was stamped on arrival.
  bool active() const { return active_; }

 private:
  static std::int64_t RealtimeNs() {
    timespec now{};
    clock_gettime(CLOCK_REALTIME, &now);
    return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
  }
  /// The SCM_TIMESTAMPNS stamp (CLOCK_REALTIME, ns) of the next datagram; 0 when none.
  std::int64_t ReadStamp() const {
    char byte = 0;
    iovec iov{&byte, 1};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))] = {};
    msghdr message{};
    message.msg_iov = &iov;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof control;
    if (::recvmsg(fd_, &message, 0) < 0) return 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec stamp{};
        std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
        return static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000 + stamp.tv_nsec;
      }
    }
    return 0;
  }

  int fd_ = -1;
  bool active_ = false;
};

}  // namespace teleop::test
