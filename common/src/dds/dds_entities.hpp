#pragma once

// Private to the dds library: small owners of Cyclone DDS entities and the QoS of every topic (docs/dds.md,
// "QoS"). Set-up errors throw teleop::Error with Cyclone's own reason.

#include <dds/dds.h>

#include <string>

namespace teleop::dds {

/// The QoS of each bridge topic, for writers and the matching readers.
enum class WriterQos {
  kState,    ///< reliable, volatile, keep last 10: the ROS 2 default profile.
  kEvents,   ///< reliable, volatile, keep last 100.
  kSummary,  ///< reliable, transient local, keep last 1 (a late subscriber still gets it while the process lives).
};

/// A QoS object for `kind` (plain CDR data representation, as rmw_cyclonedds). The caller deletes it.
dds_qos_t* MakeQos(WriterQos kind);

/// Throws teleop::Error "dds: <what>: <Cyclone's reason>" when `rc` is negative; returns rc otherwise.
dds_entity_t Check(dds_entity_t rc, const std::string& what);

/// A domain participant; deleting it deletes everything created under it.
class Participant {
 public:
  explicit Participant(int domain_id);
  ~Participant() { Close(); }
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  dds_entity_t handle() const noexcept { return handle_; }
  void Close() noexcept;

 private:
  dds_entity_t handle_ = 0;
};

/// A topic plus its data writer.
class Writer {
 public:
  Writer(const Participant& participant, const dds_topic_descriptor_t* type, const std::string& topic_name,
         WriterQos qos);
  /// dds_write; false (logged once by the caller's counters) when Cyclone refused the sample.
  [[nodiscard]] bool Write(const void* sample) const noexcept { return dds_write(writer_, sample) >= 0; }
  /// Waits until every matched reliable reader acknowledged everything written, at most `timeout`.
  void WaitForAcks(dds_duration_t timeout) const noexcept { (void)dds_wait_for_acks(writer_, timeout); }
  dds_entity_t handle() const noexcept { return writer_; }

 private:
  dds_entity_t topic_ = 0;
  dds_entity_t writer_ = 0;
};

}  // namespace teleop::dds
