// teleop-master: device -> law -> link, see common/include/teleop/node/process_main.hpp.
#include "teleop/node/process_main.hpp"

int main(int argc, char** argv) { return teleop::node::ProcessMain(argc, argv, teleop::Role::kMaster); }
