#include "dds_entities.hpp"

#include "teleop/error.hpp"

namespace teleop::dds {

dds_qos_t* MakeQos(WriterQos kind) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  switch (kind) {
    case WriterQos::kState:
      dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
      dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
      break;
    case WriterQos::kEvents:
      dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
      dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 100);
      break;
    case WriterQos::kSummary:
      dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
      break;
  }
  // Plain CDR (XCDR1), what rmw_cyclonedds writes and expects for final types.
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
  return qos;
}

dds_entity_t Check(dds_entity_t rc, const std::string& what) {
  if (rc < 0) throw Error("dds: " + what + ": " + dds_strretcode(rc));
  return rc;
}

Participant::Participant(int domain_id) {
  handle_ = dds_create_participant(static_cast<dds_domainid_t>(domain_id), nullptr, nullptr);
  if (handle_ < 0) {
    const dds_entity_t rc = handle_;
    handle_ = 0;
    throw Error("dds: cannot join domain " + std::to_string(domain_id) + ": " + dds_strretcode(rc) +
                "; check dds.domain_id and CYCLONEDDS_URI (docs/dds.md)");
  }
}

void Participant::Close() noexcept {
  if (handle_ > 0) (void)dds_delete(handle_);
  handle_ = 0;
}

Writer::Writer(const Participant& participant, const dds_topic_descriptor_t* type, const std::string& topic_name,
               WriterQos qos_kind) {
  topic_ = Check(dds_create_topic(participant.handle(), type, topic_name.c_str(), nullptr, nullptr),
                 "cannot create topic " + topic_name);
  dds_qos_t* qos = MakeQos(qos_kind);
  writer_ = dds_create_writer(participant.handle(), topic_, qos, nullptr);
  dds_delete_qos(qos);
  Check(writer_, "cannot create a writer for " + topic_name);
}

}  // namespace teleop::dds
