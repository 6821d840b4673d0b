#pragma once

// Test helpers for the Modbus tests: the pymodbus server (tests/fieldbus/modbus_server.py) as a child process with
// its control port, a socat pty pair for RTU, and running a command (mbpoll) for its output.

#include <memory>
#include <string>
#include <vector>

#include "test_utilities/temp_dir.hpp"

namespace teleop::test {

/// A child process started with posix_spawn; its stdout is a pipe. Killed (SIGTERM, then SIGKILL) on destruction.
class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// One line of the child's stdout (without the newline), waiting at most `timeout_s`; empty on timeout or EOF.
  std::string ReadLine(double timeout_s);
  /// All of the child's stdout until it closes it (or `timeout_s` passes).
  std::string ReadAll(double timeout_s);
  /// Waits at most `timeout_s` for the child to exit; its exit code, or -1 (killed, or killed by a signal).
  int Wait(double timeout_s) noexcept;
  /// Terminates the child and waits for it. Idempotent.
  void Kill() noexcept;
  int pid() const noexcept { return pid_; }

 private:
  int pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_;
};

/// The pymodbus test server. Throws std::runtime_error when it does not come up.
class ModbusTestServer {
 public:
  /// TCP on 127.0.0.1, a free port.
  static ModbusTestServer Tcp(int unit_id = 1);
  /// RTU on `device` (one end of a pty pair), 19200 baud, 8N1 (a pty refuses parity).
  static ModbusTestServer Rtu(const std::string& device, int unit_id = 1);

  int modbus_port() const noexcept { return modbus_port_; }
  /// One control command (see modbus_server.py); returns the reply line ("" when the server is gone).
  std::string Control(const std::string& command);
  /// The server process goes away (a dead device): its TCP port refuses connections.
  void Kill() noexcept { process_->Kill(); }

  ModbusTestServer(ModbusTestServer&&) = default;
  ~ModbusTestServer();

 private:
  explicit ModbusTestServer(const std::vector<std::string>& argv);
  std::unique_ptr<ChildProcess> process_;
  int modbus_port_ = 0;
  int control_port_ = 0;
};

/// Two linked pseudo-terminals made by socat: `server_end()` for the server, `client_end()` for the I/O thread.
class PtyPair {
 public:
  PtyPair();  ///< Throws std::runtime_error when socat does not make them.
  ~PtyPair();
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;
  const std::string& server_end() const noexcept { return server_; }
  const std::string& client_end() const noexcept { return client_; }

 private:
  ScopedTempDir dir_{"modbus-pty"};  ///< Removed last, after socat is gone.
  std::string server_;
  std::string client_;
  std::unique_ptr<ChildProcess> socat_;
};

/// Runs `argv` to completion (at most `timeout_s`), returns its stdout; `exit_code` receives the exit status.
std::string RunCommand(const std::vector<std::string>& argv, double timeout_s, int* exit_code);

}  // namespace teleop::test
