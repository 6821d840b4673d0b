// teleop-udp-pingpong: the physical floor of a UDP round trip between two processes on this machine.
//
// A parent and a forked child each bind a UDP socket on 127.0.0.1; the parent sends a datagram of --bytes bytes,
// the child echoes it, the parent times the round trip with CLOCK_MONOTONIC around the send and the blocking
// receive. Prints one JSON object: {"bytes":..,"count":..,"p50_us":..,"p99_us":..,"max_us":..,"min_us":..}.
// 64 bytes is a 1-DOF teleop sample (36 header + 24 per DOF + 4 CRC), 184 bytes a 6-DOF sample.
//
//   teleop-udp-pingpong [--bytes N] [--count N] [--warmup N] [--busy] [--fifo PRIO] [--cpu A,B]
//
// --busy: both sides spin on a non-blocking receive instead of sleeping in recv (what a spinning cycle would do).
// --fifo PRIO: SCHED_FIFO at PRIO for both processes (root). --cpu A,B: pin the parent to A and the child to B.
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

enum { kMaxBytes = 1472 };

static int64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static int bound_socket(struct sockaddr_in* addr) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) {
    perror("teleop-udp-pingpong: socket");
    exit(2);
  }
  memset(addr, 0, sizeof *addr);
  addr->sin_family = AF_INET;
  addr->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr->sin_port = 0;
  socklen_t len = sizeof *addr;
  if (bind(fd, (struct sockaddr*)addr, sizeof *addr) != 0 || getsockname(fd, (struct sockaddr*)addr, &len) != 0) {
    perror("teleop-udp-pingpong: bind");
    exit(2);
  }
  return fd;
}

static ssize_t receive(int fd, unsigned char* buf, int busy) {
  for (;;) {
    const ssize_t n = recv(fd, buf, kMaxBytes, busy ? MSG_DONTWAIT : 0);
    if (n >= 0) return n;
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
    return -1;
  }
}

static void apply(int fifo, int cpu) {
  if (cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) perror("teleop-udp-pingpong: sched_setaffinity (ignored)");
  }
  if (fifo > 0) {
    struct sched_param p = {.sched_priority = fifo};
    if (sched_setscheduler(0, SCHED_FIFO, &p) != 0) perror("teleop-udp-pingpong: SCHED_FIFO (ignored)");
  }
}

static int compare(const void* a, const void* b) {
  const int64_t x = *(const int64_t*)a;
  const int64_t y = *(const int64_t*)b;
  return (x > y) - (x < y);
}

int main(int argc, char** argv) {
  int bytes = 64, count = 20000, warmup = 1000, busy = 0, fifo = 0, cpu_parent = -1, cpu_child = -1;
  for (int i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--bytes") == 0 && i + 1 < argc) {
      bytes = atoi(argv[++i]);
    } else if (strcmp(argv[i], "--count") == 0 && i + 1 < argc) {
      count = atoi(argv[++i]);
    } else if (strcmp(argv[i], "--warmup") == 0 && i + 1 < argc) {
      warmup = atoi(argv[++i]);
    } else if (strcmp(argv[i], "--busy") == 0) {
      busy = 1;
    } else if (strcmp(argv[i], "--fifo") == 0 && i + 1 < argc) {
      fifo = atoi(argv[++i]);
    } else if (strcmp(argv[i], "--cpu") == 0 && i + 1 < argc) {
      if (sscanf(argv[++i], "%d,%d", &cpu_parent, &cpu_child) != 2) {
        fprintf(stderr, "teleop-udp-pingpong: --cpu takes A,B\n");
        return 1;
      }
    } else {
      fprintf(stderr, "usage: %s [--bytes N] [--count N] [--warmup N] [--busy] [--fifo PRIO] [--cpu A,B]\n", argv[0]);
      return 1;
    }
  }
  if (bytes < 1 || bytes > kMaxBytes || count < 1 || warmup < 0 || fifo < 0 || fifo > 99) {
    fprintf(stderr, "teleop-udp-pingpong: --bytes 1..%d, --count >= 1, --warmup >= 0, --fifo 0..99\n", kMaxBytes);
    return 1;
  }

  struct sockaddr_in parent_addr, child_addr;
  const int parent_fd = bound_socket(&parent_addr);
  const int child_fd = bound_socket(&child_addr);
  const pid_t child = fork();
  if (child < 0) {
    perror("teleop-udp-pingpong: fork");
    return 2;
  }
  if (child == 0) {
    close(parent_fd);
    apply(fifo, cpu_child);
    unsigned char buf[kMaxBytes];
    for (int i = 0; i < warmup + count; ++i) {
      const ssize_t n = receive(child_fd, buf, busy);
      if (n < 0) _exit(3);
      if (sendto(child_fd, buf, (size_t)n, 0, (struct sockaddr*)&parent_addr, sizeof parent_addr) != n) _exit(3);
    }
    _exit(0);
  }
  close(child_fd);
  apply(fifo, cpu_parent);
  unsigned char out[kMaxBytes], in[kMaxBytes];
  memset(out, 0xA5, sizeof out);
  int64_t* rtt = malloc(sizeof(int64_t) * (size_t)count);
  if (rtt == NULL) return 2;
  // Bound: a lost datagram (none on loopback) must not hang the run: 2 s receive timeout in blocking mode.
  struct timeval timeout = {.tv_sec = 2, .tv_usec = 0};
  setsockopt(parent_fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  for (int i = 0; i < warmup + count; ++i) {
    memcpy(out, &i, sizeof i);
    const int64_t t0 = now_ns();
    if (sendto(parent_fd, out, (size_t)bytes, 0, (struct sockaddr*)&child_addr, sizeof child_addr) != bytes) {
      perror("teleop-udp-pingpong: sendto");
      kill(child, SIGKILL);
      return 2;
    }
    const ssize_t n = receive(parent_fd, in, busy);
    const int64_t t1 = now_ns();
    if (n != bytes) {
      fprintf(stderr, "teleop-udp-pingpong: echo %d lost or short\n", i);
      kill(child, SIGKILL);
      return 2;
    }
    if (i >= warmup) rtt[i - warmup] = t1 - t0;
  }
  int status = 0;
  waitpid(child, &status, 0);
  qsort(rtt, (size_t)count, sizeof rtt[0], compare);
  const double p50 = (double)rtt[count / 2] / 1e3;
  const double p99 = (double)rtt[(int)((double)count * 0.99) < count ? (int)((double)count * 0.99) : count - 1] / 1e3;
  printf(
      "{\"bytes\": %d, \"count\": %d, \"busy\": %s, \"fifo\": %d, \"min_us\": %.2f, \"p50_us\": %.2f, "
      "\"p99_us\": %.2f, \"max_us\": %.2f}\n",
      bytes, count, busy ? "true" : "false", fifo, (double)rtt[0] / 1e3, p50, p99, (double)rtt[count - 1] / 1e3);
  free(rtt);
  return 0;
}
