#pragma once

// A CiA 402 drive's EDS against the client's configuration (docs/cia402.md, "EDS"): every object the configured
// client reads, writes or maps exists with the data type, access and PDO mapping it needs; the configured PDOs fit
// the drive's PDO count and mapping capacity; the configured mode is in the EDS's 0x6502 default. Set-up only.

#include <string>
#include <vector>

#include "teleop/fieldbus/canopen_eds.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"

namespace teleop::fieldbus {

/// Every mismatch, each naming the file, the section and the key ("drive.eds: [6060] DataType is 0x0005
/// (UNSIGNED8), the client writes INTEGER8 (0x0002): modes of operation"). Empty when the EDS fits.
std::vector<std::string> CheckAgainstEds(const canopen::Eds& eds, const Cia402DriveConfig& config);

/// PDOs with cob_id 0 (the predefined default) take the EDS's default COB-ID (0x1400+n / 0x1800+n sub 1
/// DefaultValue, $NODEID evaluated), so ReceiveOptions and the mapping use the drive's own defaults.
void ApplyEdsDefaults(const canopen::Eds& eds, Cia402DriveConfig& config);

/// Loads config.eds_file (when set), applies its defaults and checks it; throws teleop::Error listing every
/// mismatch. Call before building the drive's port (the COB-IDs may change).
void ApplyEds(Cia402DriveConfig& config);

}  // namespace teleop::fieldbus
