// teleop-master: device -> law -> link, see common/include/teleop/node/teleop_node.hpp.
#include "teleop/node/teleop_node.hpp"

int main(int argc, char** argv) { return teleop::node::ProcessMain(argc, argv, teleop::Role::kMaster); }
