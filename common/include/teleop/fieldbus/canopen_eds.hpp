#pragma once

// CANopen electronic data sheets (EDS) and device configuration files (DCF), CiA 306: an INI file with one section per
// object ([1018]) and sub-object ([1018sub1]), listed in [MandatoryObjects], [OptionalObjects] and
// [ManufacturerObjects]; each has ParameterName, ObjectType (0x7 VAR, 0x8 ARRAY, 0x9 RECORD), DataType (0x0007
// UNSIGNED32, …), AccessType (ro, wo, rw, rwr, rww, const), DefaultValue (decimal, 0x hex, or with $NODEID),
// PDOMapping (0/1) and, for arrays and records, SubNumber. [DeviceInfo] has NrOfRXPDO / NrOfTXPDO. Read with
// boost::property_tree's INI parser; section names are matched case-insensitively. Set-up only (throws
// teleop::Error naming the file, the section and the key).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace teleop::fieldbus::canopen {

/// CiA 301 data type indices (Table "Object dictionary data types").
namespace datatype {
inline constexpr std::uint16_t kBoolean = 0x0001;
inline constexpr std::uint16_t kInteger8 = 0x0002;
inline constexpr std::uint16_t kInteger16 = 0x0003;
inline constexpr std::uint16_t kInteger32 = 0x0004;
inline constexpr std::uint16_t kUnsigned8 = 0x0005;
inline constexpr std::uint16_t kUnsigned16 = 0x0006;
inline constexpr std::uint16_t kUnsigned32 = 0x0007;
inline constexpr std::uint16_t kReal32 = 0x0008;
inline constexpr std::uint16_t kVisibleString = 0x0009;
inline constexpr std::uint16_t kOctetString = 0x000A;
inline constexpr std::uint16_t kDomain = 0x000F;
}  // namespace datatype
/// "UNSIGNED32", or "0x1234" for a type not in the table.
std::string DataTypeName(std::uint16_t type);

/// One object or sub-object of an EDS.
struct EdsEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::string section;  ///< As written in the file: "1018sub1".
  std::string name;     ///< ParameterName.
  std::uint8_t object_type = 0x7;
  std::optional<std::uint16_t> data_type;  ///< DataType (absent for ARRAY/RECORD tops).
  std::string access;                      ///< AccessType, lower case.
  std::string default_value;               ///< DefaultValue as written.
  bool pdo_mapping = false;
  int sub_number = 0;  ///< SubNumber (arrays/records).

  bool readable() const noexcept;  ///< ro, rw, rwr, rww, const.
  bool writable() const noexcept;  ///< wo, rw, rwr, rww.
};

class Eds {
 public:
  /// Reads and parses `path`; throws teleop::Error naming the file (and the line of an INI syntax error, the section
  /// and key of a malformed value).
  static Eds Load(const std::string& path);
  /// Parses `text`; `file` names it in messages.
  static Eds Parse(const std::string& text, const std::string& file);

  const std::string& file() const noexcept { return file_; }
  /// The object index:subindex (a VAR is sub 0 of its own section), or nullptr.
  const EdsEntry* Find(std::uint16_t index, std::uint8_t subindex) const noexcept;
  /// Whether index has a section at all (a VAR, ARRAY or RECORD).
  bool Has(std::uint16_t index) const noexcept;
  /// [DeviceInfo] NrOfRXPDO / NrOfTXPDO (0 when absent).
  int rx_pdo_count() const noexcept { return rx_pdos_; }
  int tx_pdo_count() const noexcept { return tx_pdos_; }
  /// How many entries PDO mapping object `mapping_index` (0x1600+n / 0x1A00+n) takes: its highest sub-object.
  int MappingCapacity(std::uint16_t mapping_index) const noexcept;
  /// DefaultValue of index:subindex evaluated for `node_id` ($NODEID), or nothing when absent or empty. Throws
  /// when present but malformed.
  std::optional<std::uint32_t> DefaultValue(std::uint16_t index, std::uint8_t subindex, std::uint8_t node_id) const;
  std::size_t size() const noexcept { return entries_.size(); }
  const std::map<std::uint32_t, EdsEntry>& entries() const noexcept { return entries_; }

 private:
  std::string file_;
  std::map<std::uint32_t, EdsEntry> entries_;  ///< key index << 8 | subindex
  std::map<std::uint16_t, bool> objects_;
  int rx_pdos_ = 0;
  int tx_pdos_ = 0;
};

/// A CiA 306 number: decimal, 0x hexadecimal, leading-0 octal, or a sum with $NODEID ("$NODEID+0x180").
/// False when malformed.
[[nodiscard]] bool ParseEdsValue(const std::string& text, std::uint8_t node_id, std::uint32_t& value) noexcept;

}  // namespace teleop::fieldbus::canopen
