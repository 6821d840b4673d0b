// The CiA 402 state machine: statusword decoding (every state, with the don't-care bits set), the master's next
// controlword toward Operation Enabled, and the drive-side transitions 2..16 with their numbers.
#include "teleop/fieldbus/cia402_state_machine.hpp"

#include <gtest/gtest.h>

namespace teleop::fieldbus::cia402 {
namespace {

TEST(Cia402StateMachine, DecodesEveryStateIgnoringDontCareBits) {
  struct Case {
    std::uint16_t statusword;
    DriveState state;
  };
  // CiA 402 Table "State coding" (bits 6, 5, 3, 2, 1, 0), with voltage/warning/remote/target bits around them.
  const Case cases[] = {
      {0x0000, DriveState::kNotReadyToSwitchOn},
      {0x0020, DriveState::kNotReadyToSwitchOn},
      {0x0040, DriveState::kSwitchOnDisabled},
      {0x0260, DriveState::kSwitchOnDisabled},
      {0x0021, DriveState::kReadyToSwitchOn},
      {0x0231, DriveState::kReadyToSwitchOn},
      {0x0023, DriveState::kSwitchedOn},
      {0x0233, DriveState::kSwitchedOn},
      {0x0027, DriveState::kOperationEnabled},
      {0x1637, DriveState::kOperationEnabled},
      {0x0007, DriveState::kQuickStopActive},
      {0x0217, DriveState::kQuickStopActive},
      {0x000F, DriveState::kFaultReactionActive},
      {0x002F, DriveState::kFaultReactionActive},
      {0x0008, DriveState::kFault},
      {0x0228, DriveState::kFault},
      {0x0041, DriveState::kUnknown},
      {0x0061, DriveState::kUnknown},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(DecodeStatusword(c.statusword), c.state) << std::hex << c.statusword;
  }
  for (const DriveState s : {DriveState::kSwitchOnDisabled, DriveState::kReadyToSwitchOn, DriveState::kSwitchedOn,
                             DriveState::kOperationEnabled, DriveState::kQuickStopActive, DriveState::kFault,
                             DriveState::kFaultReactionActive}) {
    EXPECT_EQ(DecodeStatusword(StatuswordBits(s)), s) << ToString(s);
  }
}

TEST(Cia402StateMachine, MasterStepsTowardOperationEnabled) {
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kSwitchOnDisabled, 0), 0x0006);
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kReadyToSwitchOn, 0x0006), 0x0007);
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kSwitchedOn, 0x0007), 0x000F);
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kQuickStopActive, 0x0002), 0x000F);
  // Fault reset acts on a rising edge of bit 7: after 0x80, 0 first.
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kFault, 0x000F), 0x0080);
  EXPECT_EQ(ControlwordTowardOperationEnabled(DriveState::kFault, 0x0080), 0x0000);
}

TEST(Cia402StateMachine, DriveTransitionsAreNumberedAsInTheStandard) {
  DriveStateMachine m;
  EXPECT_EQ(m.state(), DriveState::kNotReadyToSwitchOn);
  EXPECT_EQ(m.Apply(cw::kCmdShutdown, true), 0);  // nothing before initialisation ends
  m.FinishInitialisation();                       // 0 + 1
  EXPECT_EQ(m.state(), DriveState::kSwitchOnDisabled);
  EXPECT_EQ(m.Statusword(), 0x0040);
  EXPECT_EQ(m.Apply(cw::kCmdSwitchOn, true), 0);  // Switch On is not accepted in Switch On Disabled
  EXPECT_EQ(m.Apply(cw::kCmdShutdown, true), 2);
  EXPECT_EQ(m.Statusword(), 0x0031);
  EXPECT_EQ(m.Apply(cw::kCmdSwitchOn, true), 3);
  EXPECT_EQ(m.Apply(cw::kCmdEnableOperation, true), 4);
  EXPECT_EQ(m.Statusword(), 0x0037);
  EXPECT_EQ(m.Apply(cw::kCmdSwitchOn, true), 5);
  EXPECT_EQ(m.Apply(cw::kCmdShutdown, true), 6);
  EXPECT_EQ(m.Apply(cw::kCmdDisableVoltage, true), 7);
  EXPECT_EQ(m.Apply(cw::kCmdShutdown, true), 2);
  EXPECT_EQ(m.Apply(cw::kCmdEnableOperation, true), 4);  // 3 + 4 from Ready To Switch On
  EXPECT_EQ(m.Apply(cw::kCmdShutdown, true), 8);
  EXPECT_EQ(m.Apply(cw::kCmdEnableOperation, true), 4);
  EXPECT_EQ(m.Apply(cw::kCmdDisableVoltage, true), 9);
  (void)m.Apply(cw::kCmdShutdown, true);
  (void)m.Apply(cw::kCmdSwitchOn, true);
  EXPECT_EQ(m.Apply(cw::kCmdQuickStop, true), 10);
  (void)m.Apply(cw::kCmdShutdown, true);
  (void)m.Apply(cw::kCmdEnableOperation, true);
  // Quick stop: 0x605A 0..4 ends in Switch On Disabled, 5..8 stays in Quick Stop Active (left by 16 or 12).
  EXPECT_EQ(m.Apply(cw::kCmdQuickStop, true), 11);
  EXPECT_EQ(m.state(), DriveState::kSwitchOnDisabled);
  (void)m.Apply(cw::kCmdShutdown, false);
  (void)m.Apply(cw::kCmdEnableOperation, false);
  EXPECT_EQ(m.Apply(cw::kCmdQuickStop, false), 11);
  EXPECT_EQ(m.state(), DriveState::kQuickStopActive);
  EXPECT_EQ(m.Statusword(), 0x0017);
  EXPECT_EQ(m.Apply(cw::kCmdEnableOperation, false), 16);
  (void)m.Apply(cw::kCmdQuickStop, false);
  EXPECT_EQ(m.Apply(cw::kCmdDisableVoltage, false), 12);
  // Fault: 13, 14, then 15 only on the rising edge of bit 7.
  m.Fault();
  EXPECT_EQ(m.state(), DriveState::kFaultReactionActive);
  EXPECT_EQ(m.Apply(cw::kCmdFaultReset, true), 0);  // not while the reaction runs
  m.FaultReactionDone();
  EXPECT_EQ(m.state(), DriveState::kFault);
  EXPECT_EQ(m.Apply(cw::kCmdFaultReset, true), 0);  // bit 7 was already high: no edge
  EXPECT_EQ(m.Apply(cw::kCmdDisableVoltage, true), 0);
  EXPECT_EQ(m.Apply(cw::kCmdFaultReset, true), 15);
  EXPECT_EQ(m.state(), DriveState::kSwitchOnDisabled);
}

}  // namespace
}  // namespace teleop::fieldbus::cia402
