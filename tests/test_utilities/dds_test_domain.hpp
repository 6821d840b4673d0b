#pragma once

#include <unistd.h>

#include <cstdlib>

namespace teleop::test {

/// A DDS domain of the test's own (other test runs on this machine use others: 150 + (pid + offset) mod 80) with
/// Cyclone confined to loopback unicast (CYCLONEDDS_URI, set once, before the first participant). Tests that may run
/// at the same time in one ctest pass use different offsets.
inline int LoopbackDdsDomain(int offset) {
  static const int domain = [offset] {
    const char* xml =
        "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
        "<MaxAutoParticipantIndex>20</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers>"
        "</Discovery></Domain></CycloneDDS>";
    setenv("CYCLONEDDS_URI", xml, 1);
    return 150 + static_cast<int>((getpid() + offset) % 80);
  }();
  return domain;
}

}  // namespace teleop::test
