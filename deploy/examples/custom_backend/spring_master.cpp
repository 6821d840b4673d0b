// spring-master: teleop-master with the example-spring backend compiled in (spring_device.cpp registers it). The
// whole process (command line, config, stability check, lifecycle, signals, summary) is teleop's ProcessMain, so
//   spring-master --config master.yaml
// pairs with an unmodified teleop-slave (slave.yaml here, on the loopback plant).
#include "teleop/node/process_main.hpp"

int main(int argc, char** argv) { return teleop::node::ProcessMain(argc, argv, teleop::Role::kMaster); }
