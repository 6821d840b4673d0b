#include "teleop/fieldbus/canopen_sync_producer.hpp"

#include <string>

#include "teleop/error.hpp"

namespace teleop::fieldbus::canopen {

SyncProducer::SyncProducer(transport::CanPort& port, std::uint32_t cob_id) : port_(port), cob_id_(cob_id) {
  if (cob_id == cob::kNmt || cob_id > 0x7FFu) {
    throw Error("SYNC COB-ID " + std::to_string(cob_id) + " is not an 11-bit identifier other than 0 (NMT)");
  }
}

transport::CanWriteStatus SyncProducer::Send() noexcept {
  const transport::CanWriteStatus status = port_.Write(EncodeSync(cob_id_));
  if (status == transport::CanWriteStatus::kOk) {
    ++counters_.sent;
  } else {
    ++counters_.write_failures;
  }
  return status;
}

}  // namespace teleop::fieldbus::canopen
