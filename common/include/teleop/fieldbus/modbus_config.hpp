#pragma once

// What the Modbus I/O thread talks to and how (docs/modbus.md): the bus (TCP or RTU), the unit, the timing that bounds
// fault detection, and the register map that turns registers into SI values and back.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace teleop::fieldbus {

/// Most points one direction of the register map may have (the loop-side records are fixed-size).
inline constexpr int kMaxModbusPoints = 16;

enum class ModbusTransport : std::uint8_t {
  kTcp,  ///< Modbus TCP (MBAP header, port 502 by default).
  kRtu,  ///< Modbus RTU on a serial line (RS-232/RS-485, CRC-16).
};

/// Which of the four Modbus data tables a point lives in.
enum class ModbusTable : std::uint8_t {
  kCoil,             ///< 1 bit, read (FC 1) / write (FC 5).
  kDiscreteInput,    ///< 1 bit, read-only (FC 2).
  kInputRegister,    ///< 16 bits, read-only (FC 4).
  kHoldingRegister,  ///< 16 bits, read (FC 3) / write (FC 6 for one register, FC 16 for two).
};

/// How the register word(s) of a point encode its raw integer. Bits (coils, discrete inputs) ignore it.
enum class ModbusValueType : std::uint8_t {
  kUint16,  ///< One register, 0..65535.
  kInt16,   ///< One register, two's complement, -32768..32767.
  kUint32,  ///< Two consecutive registers.
  kInt32,   ///< Two consecutive registers, two's complement.
};

/// Order of the two registers of a 32-bit value (the bytes inside a register are always big-endian, per the standard).
enum class ModbusWordOrder : std::uint8_t {
  kHighWordFirst,  ///< Register `address` holds bits 31..16 ("big-endian", most devices).
  kLowWordFirst,   ///< Register `address` holds bits 15..0 ("word-swapped").
};

/// One value of the register map. SI value = raw * scale + offset; a command is converted back with rounding to the
/// nearest raw value and clamped to the type's range (counted, never silent).
struct ModbusPoint {
  std::string name;  ///< For messages and telemetry ("brake_torque_Nm").
  ModbusTable table = ModbusTable::kHoldingRegister;
  int address = 0;  ///< 0-based protocol address (register 40001 of a data sheet is holding address 0).
  ModbusValueType type = ModbusValueType::kInt16;
  ModbusWordOrder word_order = ModbusWordOrder::kHighWordFirst;
  double scale = 1.0;   ///< SI units per raw count (non-zero, finite).
  double offset = 0.0;  ///< SI value at raw 0.
  /// Outputs only: the SI value written when the loop has no fresh command (start, command timeout, Stop()).
  double safe_value = 0.0;
};

struct ModbusTcpConfig {
  std::string host = "127.0.0.1";  ///< Numeric IPv4/IPv6 address or host name.
  int port = 502;
};

struct ModbusRtuConfig {
  std::string device;  ///< Serial device ("/dev/ttyUSB0").
  int baud = 19200;
  char parity = 'E';  ///< 'N', 'E' or 'O' (the Modbus standard's default is even).
  int data_bits = 8;
  int stop_bits = 1;
};

/// Everything the I/O thread needs. Durations in ms (as in the YAML section). Validate() states the rules.
struct ModbusConfig {
  ModbusTransport transport = ModbusTransport::kTcp;
  ModbusTcpConfig tcp;
  ModbusRtuConfig rtu;
  int unit_id = 1;  ///< Unit (slave) address: 1..247 on RTU; 0..255 on TCP (gateways often want 255 or 1).

  double poll_period_ms = 10.0;       ///< One cycle: write all outputs, then read all inputs.
  double response_timeout_ms = 50.0;  ///< Bound of one transaction (libmodbus response timeout), >= 1 ms.
  /// 0 (default): the whole answer must arrive within response_timeout_ms, the strict bound. > 0: libmodbus waits
  /// response_timeout_ms for the first byte only, then up to this long for each further byte (a looser bound).
  double byte_timeout_ms = 0.0;
  double connect_timeout_ms = 500.0;  ///< Bound of one TCP connect / serial open, >= 1 ms.
  /// A lost connection is retried at once; after a failed connect the thread waits this long, doubling the wait with
  /// each further failure in a row...
  double reconnect_initial_ms = 50.0;
  double reconnect_max_ms = 1000.0;  ///< ...up to this.
  /// A reading older than this (since its poll completed) is a communication fault, seen by the loop whatever the
  /// I/O thread is doing: the configured bound of fault detection. Must exceed poll_period_ms + response_timeout_ms.
  double stale_after_ms = 100.0;
  /// The I/O thread writes the outputs' safe values when the loop has published no new command for this long
  /// (0 = never: the newest command is held).
  double command_timeout_ms = 200.0;

  std::vector<ModbusPoint> inputs;   ///< Read every cycle, in this order into ModbusReading::values.
  std::vector<ModbusPoint> outputs;  ///< Written every cycle from ModbusCommand::values, in this order.
};

/// Throws teleop::Error naming the field when the config is unusable: ranges, timing relations, an output in a
/// read-only table, more than kMaxModbusPoints points, a point past address 65535, overlapping outputs, two points
/// of one direction with the same name.
void Validate(const ModbusConfig& config);

/// "holding_register", "int32", "high_word_first", ... (the YAML spellings).
const char* ToString(ModbusTable table) noexcept;
const char* ToString(ModbusValueType type) noexcept;
const char* ToString(ModbusWordOrder order) noexcept;
/// Registers a point occupies (1 for 16-bit values and bits, 2 for 32-bit values).
int RegisterCount(const ModbusPoint& point) noexcept;
/// Index of the point called `name` in `points` (its slot in ModbusReading/ModbusCommand::values); -1 when absent.
/// Set-up only: a backend looks its points up once by name.
int FindPoint(const std::vector<ModbusPoint>& points, std::string_view name) noexcept;

}  // namespace teleop::fieldbus
