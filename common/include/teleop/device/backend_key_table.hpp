#pragma once

// A backend adopts its key table (teleop/config/key_spec.hpp): the table becomes DeviceBackend::key_table (the docs
// rows, tests/config/configuration_docs_test.cpp) and each key a `keys` entry with its DescribeKey line
// (`--list-devices`). For the backends' own sources and out-of-tree backends; needs teleop::config_reader.

#include <iterator>

#include "teleop/config/key_table.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::device {

/// Appends every KeySpec of `table` (an array or other range of them) to `backend`'s key_table and keys.
template <typename Table>
void AdoptKeyTable(DeviceBackend& backend, const Table& table) {
  for (const config::KeySpec& spec : table) {
    backend.key_table.push_back(spec);
    backend.keys.push_back({spec.key, config::DescribeKey(spec)});
  }
}

}  // namespace teleop::device
