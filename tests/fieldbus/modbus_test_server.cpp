#include "modbus_test_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <utility>

extern char** environ;

namespace teleop::test {

namespace {

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

ChildProcess::ChildProcess(const std::vector<std::string>& argv) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    pid_ = -1;
    throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  }
  stdout_fd_ = fds[0];
}

ChildProcess::~ChildProcess() {
  Kill();
  if (stdout_fd_ >= 0) close(stdout_fd_);
}

std::string ChildProcess::ReadLine(double timeout_s) {
  const double deadline = Now() + timeout_s;
  while (true) {
    const std::size_t nl = buffer_.find('\n');
    if (nl != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      return line;
    }
    const double left = deadline - Now();
    if (left <= 0.0 || stdout_fd_ < 0) return {};
    pollfd p{stdout_fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left * 1000.0) + 1) <= 0) continue;
    char chunk[512];
    const ssize_t n = read(stdout_fd_, chunk, sizeof chunk);
    if (n <= 0) return {};
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
}

std::string ChildProcess::ReadAll(double timeout_s) {
  const double deadline = Now() + timeout_s;
  while (stdout_fd_ >= 0) {
    const double left = deadline - Now();
    if (left <= 0.0) break;
    pollfd p{stdout_fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left * 1000.0) + 1) <= 0) continue;
    char chunk[512];
    const ssize_t n = read(stdout_fd_, chunk, sizeof chunk);
    if (n <= 0) break;
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
  return std::exchange(buffer_, std::string());
}

int ChildProcess::Wait(double timeout_s) noexcept {
  if (pid_ <= 0) return -1;
  const double deadline = Now() + timeout_s;
  while (Now() < deadline) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  Kill();
  return -1;
}

void ChildProcess::Kill() noexcept {
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  for (int i = 0; i < 200; ++i) {
    if (waitpid(pid_, nullptr, WNOHANG) == pid_) {
      pid_ = -1;
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
  pid_ = -1;
}

ModbusTestServer::ModbusTestServer(const std::vector<std::string>& argv)
    : process_(std::make_unique<ChildProcess>(argv)) {
  // The server imports pymodbus first: allow a slow, loaded machine plenty of time.
  const std::string line = process_->ReadLine(30.0);
  if (std::sscanf(line.c_str(), "READY modbus_port=%d control_port=%d", &modbus_port_, &control_port_) != 2) {
    throw std::runtime_error("the pymodbus test server did not start (said '" + line +
                             "'); is python3-pymodbus installed?");
  }
}

ModbusTestServer::~ModbusTestServer() {
  if (process_) process_->Kill();
}

ModbusTestServer ModbusTestServer::Tcp(int unit_id) {
  return ModbusTestServer(
      {TELEOP_PYTHON3, TELEOP_MODBUS_SERVER_SCRIPT, "--tcp", "127.0.0.1:0", "--unit", std::to_string(unit_id)});
}

ModbusTestServer ModbusTestServer::Rtu(const std::string& device, int unit_id) {
  return ModbusTestServer(
      {TELEOP_PYTHON3, TELEOP_MODBUS_SERVER_SCRIPT, "--rtu", device, "--unit", std::to_string(unit_id)});
}

std::string ModbusTestServer::Control(const std::string& command) {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  if (s < 0) return {};
  timeval tv{10, 0};
  setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(control_port_));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (connect(s, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    const std::string line = command + "\n";
    if (send(s, line.data(), line.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(line.size())) {
      char c = 0;
      while (recv(s, &c, 1, 0) == 1 && c != '\n') reply.push_back(c);
    }
  }
  close(s);
  return reply;
}

PtyPair::PtyPair() {
  server_ = dir_.File("server");
  client_ = dir_.File("client");
  socat_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{TELEOP_SOCAT, "pty,raw,echo=0,link=" + server_, "pty,raw,echo=0,link=" + client_});
  for (int i = 0; i < 1000; ++i) {
    struct stat st {};
    if (lstat(server_.c_str(), &st) == 0 && lstat(client_.c_str(), &st) == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  throw std::runtime_error("socat made no pty pair in " + dir_.path().string());
}

PtyPair::~PtyPair() {
  socat_->Kill();  // then dir_ removes the links socat left
}

std::string RunCommand(const std::vector<std::string>& argv, double timeout_s, int* exit_code) {
  ChildProcess child(argv);
  std::string out = child.ReadAll(timeout_s);
  const int code = child.Wait(1.0);
  if (exit_code != nullptr) *exit_code = code;
  return out;
}

}  // namespace teleop::test
