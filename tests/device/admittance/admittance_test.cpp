// The admittance backend (common/src/device/admittance) on simulated CiA 402 drives with their own position loop
// (SimulatedLoopConfig: kp = 100 rad/s, velocity loop ~600 rad/s), on the in-process emulated bus, manual clock.
//
// The assumption of its stability model: the slave is the virtual mass-damper m_v ẍ + b_v ẋ = F only while the
// drive's position loop is much faster than b_v/m_v. Under a constant force the virtual mass reaches
// v∞ = F/b_v; a first-order position loop of bandwidth kp follows a ramp of slope v with the lag v/kp, so the joint
// stays within v∞/kp (plus the cycle's two periods of transport: v∞ · 2 ms) of the closed form
// x(t) = F/b (t − m/b (1 − e^{−b t / m})). With kp = 10 · b_v/m_v that holds; with a loop slower than the virtual
// dynamics the error is several times larger and the model says "not applicable".
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "admittance_device.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "test_utilities/sync_gate.hpp"

namespace teleop::device {
namespace {

constexpr double kCountsPerRad = 1048576.0;  // 2^20: quantisation far below the lags checked

struct Rig {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [this] { return now_ns; }};
  std::vector<std::unique_ptr<transport::CanPort>> sim_ports;
  std::vector<std::unique_ptr<fieldbus::SimulatedCia402Drive>> sims;
  AdmittanceConfig config;
  std::unique_ptr<AdmittanceDevice> device;
  test::SyncGate* gate = nullptr;  ///< The first drive's host port (the device sends the SYNC on it).
  bool drives_silent = false;      ///< The simulated drives stop running (no TPDO, no heartbeat).

  explicit Rig(int dof, double m_v, double b_v, double kp = 100.0, const fieldbus::SimulatedLoopConfig* loops = nullptr,
               const fieldbus::SimulatedJointConfig* joint = nullptr) {
    config.dof = dof;
    config.virtual_mass_kg = DofVector::Constant(dof, m_v);
    config.virtual_damping_Ns_per_m = DofVector::Constant(dof, b_v);
    config.position_loop_bandwidth_rad_per_s = kp;
    for (int i = 0; i < dof; ++i) {
      AdmittanceAxisConfig a;
      a.drive.node_id = static_cast<std::uint8_t>(i + 1);
      a.drive.scaling.position_rad_per_count = 1.0 / kCountsPerRad;
      a.drive.sdo.timeout_ms = 5.0;
      a.drive.sdo.backoff_initial_ms = 1.0;
      a.drive.max_torque_Nm = 1.0;
      config.axes.push_back(a);
      fieldbus::SimulatedCia402DriveConfig s;
      s.node_id = a.drive.node_id;
      s.position_rad_per_count = 1.0 / kCountsPerRad;
      s.loops.position_kp_per_s = kp;
      if (loops != nullptr) s.loops = *loops;
      if (joint != nullptr) s.joint = *joint;
      sim_ports.push_back(bus.MakePort(bus.AddNode(), fieldbus::SimulatedCia402Drive::ReceiveOptions(s)));
      sims.push_back(std::make_unique<fieldbus::SimulatedCia402Drive>(s, *sim_ports.back()));
    }
  }
  void Build() {
    fieldbus::Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) { Advance(std::max<std::uint64_t>(ns, 1000)); };
    const auto port = [this](const transport::CanReceiveOptions& o) -> std::unique_ptr<transport::CanPort> {
      auto inner = bus.MakePort(bus.AddNode(), o);
      if (gate != nullptr) return inner;
      auto first = std::make_unique<test::SyncGate>(std::move(inner));
      gate = first.get();
      return first;
    };
    device = std::make_unique<AdmittanceDevice>(config, port, t);
  }
  void Advance(std::uint64_t ns) {
    const std::uint64_t end = now_ns + ns;
    while (now_ns < end) {
      now_ns = std::min(end, now_ns + 100'000);
      if (!drives_silent)
        for (auto& s : sims) s->Step(now_ns);
    }
  }
  /// One 1 ms cycle as the node runs it: Exchange, Read, the law (here `force`), Write, Update, then the period
  /// passes.
  Reading Cycle(const DofVector& force) {
    Reading r;
    device->Exchange();
    device->Read(r);
    device->Write(Command::Force(force));
    device->Update(config.cycle_period_s);
    Advance(1'000'000);
    return r;
  }
};

double Ideal(double F, double m, double b, double t) { return F / b * (t - m / b * (1.0 - std::exp(-b * t / m))); }

/// The largest |joint − closed form| over 1 s under F = 1 N (the joint: the drive's measured position, which the
/// device checks but does not report as the reading), and the joint's final speed.
double WorstDeviation(Rig& rig, double& speed) {
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  const double m = rig.config.virtual_mass_kg[0];
  const double b = rig.config.virtual_damping_Ns_per_m[0];
  const DofVector F = DofVector::Constant(1, 1.0);
  double worst = 0.0;
  Reading r;
  for (int k = 0; k < 1000; ++k) {
    r = rig.Cycle(F);
    EXPECT_EQ(r.faults, kFaultNone) << k;
    // The reading of cycle k was sampled at the SYNC sent at its start; the force acted from cycle 0's Update on.
    const double t = std::max(0.0, (k - 1) * 1e-3);
    worst = std::max(worst, std::abs(rig.device->measured_position_m(0) - Ideal(1.0, m, b, t)));
    // The reading is the virtual mass (the admittance's commanded state): the closed form, exactly, a cycle ahead.
    EXPECT_NEAR(r.position_m[0], Ideal(1.0, m, b, k * 1e-3), 1e-9) << k;
  }
  speed = rig.sims[0]->velocity_rad_per_s() * rig.config.axes[0].transmission_m_per_rad;
  return worst;
}

TEST(Admittance, VirtualMassDamperIsExactUnderAHeldForce) {
  VirtualAdmittance a(0.5, 5.0);
  a.Reset(0.0);
  for (int k = 0; k < 300; ++k) a.Step(1.0, 1e-3, 0.0);
  EXPECT_NEAR(a.position_m(), Ideal(1.0, 0.5, 5.0, 0.3), 1e-12);
  EXPECT_NEAR(a.velocity_m_per_s(), 0.2 * (1.0 - std::exp(-3.0)), 1e-12);
  VirtualAdmittance free(0.5, 0.0);  // b = 0: x = F t² / 2m
  for (int k = 0; k < 100; ++k) free.Step(1.0, 1e-3, 0.0);
  EXPECT_NEAR(free.position_m(), 0.5 * 1.0 / 0.5 * 0.01, 1e-12);
  free.Step(1.0, 10.0, 0.3);
  EXPECT_EQ(free.velocity_m_per_s(), 0.3);  // the speed limit
}

TEST(Admittance, WithAFastPositionLoopTheSlaveIsTheVirtualMassDamper) {
  Rig rig(1, 0.5, 5.0, 100.0);  // b_v/m_v = 10 rad/s, kp = 100 rad/s: ratio 10
  double speed = 0.0;
  const double worst = WorstDeviation(rig, speed);
  const double v_inf = 1.0 / 5.0;
  EXPECT_NEAR(speed, v_inf, 0.01 * v_inf);  // F / b_v after 1 s = 5 m_v/b_v time constants
  const double bound = v_inf / 100.0 + v_inf * 2e-3;
  EXPECT_LT(worst, bound) << "the position loop's lag bound";
  std::printf("fast loop: worst |x - x_ideal| %.3f mm, bound %.3f mm\n", worst * 1e3, bound * 1e3);
  const AnalysisModel model = AdmittanceModel(rig.config);
  ASSERT_TRUE(model.applicable) << model.reason;
  EXPECT_EQ(model.mass_kg[0], 0.5);
  EXPECT_EQ(model.damping_Ns_per_m[0], 5.0);
}

TEST(Admittance, WithASlowPositionLoopTheModelDoesNotHoldAndSaysSo) {
  Rig rig(1, 0.5, 5.0, 5.0);  // kp = 5 rad/s < b_v/m_v = 10 rad/s
  double speed = 0.0;
  const double worst = WorstDeviation(rig, speed);
  const double fast_bound = 0.2 / 100.0 + 0.2 * 2e-3;
  EXPECT_GT(worst, 5.0 * fast_bound);  // v∞/kp = 40 mm of lag against 2.4 mm
  std::printf("slow loop: worst |x - x_ideal| %.3f mm\n", worst * 1e3);
  const AnalysisModel model = AdmittanceModel(rig.config);
  EXPECT_FALSE(model.applicable);
  EXPECT_NE(model.reason.find("is not 10 times faster than the virtual dynamics b_v/m_v = 10 rad/s"), std::string::npos)
      << model.reason;
  rig.config.position_loop_bandwidth_rad_per_s = 0.0;
  EXPECT_FALSE(AdmittanceModel(rig.config).applicable);
}

// The stiffest spring counts too: m_v = 2 kg on 2600 N/m oscillates at sqrt(1300) = 36 rad/s; a 250 rad/s loop is
// 6.9 times faster (ratio 5: applicable), a 100 rad/s loop 2.8 times (not).
TEST(Admittance, TheModelChecksTheLoopAgainstTheStiffestSpring) {
  AdmittanceConfig c;
  c.dof = 1;
  c.virtual_mass_kg = DofVector::Constant(1, 2.0);
  c.virtual_damping_Ns_per_m = DofVector::Constant(1, 20.0);
  c.bandwidth_ratio = 5.0;
  c.max_stiffness_N_per_m = 2600.0;
  c.position_loop_bandwidth_rad_per_s = 250.0;
  EXPECT_TRUE(AdmittanceModel(c).applicable) << AdmittanceModel(c).reason;
  c.position_loop_bandwidth_rad_per_s = 100.0;
  const AnalysisModel m = AdmittanceModel(c);
  EXPECT_FALSE(m.applicable);
  EXPECT_NE(m.reason.find("sqrt(K/m_v) = 36.1 rad/s (max_stiffness_N_per_m 2600)"), std::string::npos) << m.reason;
}

// A fixture as the law renders it: F = F_push − K (x − x_wall) inside the wall. The virtual mass stops at
// x_wall + F_push/K, and the drive puts the joint there.
TEST(Admittance, TwoAxesFollowAndStopAtAFixture) {
  Rig rig(2, 0.2, 4.0, 100.0);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  const double K = 200.0, wall = 0.05, push = 2.0;
  Reading r;
  DofVector F(2);
  for (int k = 0; k < 2000; ++k) {
    r = k == 0 ? rig.Cycle(DofVector::Zero(2)) : r;
    for (int i = 0; i < 2; ++i) {
      const double x = rig.device->axis_model(i).position_m();
      F[i] = (i == 0 ? push : -push) - (i == 0 ? K * std::max(0.0, x - wall) : K * std::min(0.0, x + wall));
    }
    r = rig.Cycle(F);
    ASSERT_EQ(r.faults, kFaultNone) << k;
  }
  EXPECT_NEAR(r.position_m[0], wall + push / K, 1e-4);
  EXPECT_NEAR(r.position_m[1], -(wall + push / K), 1e-4);
  EXPECT_NEAR(r.velocity_m_per_s[0], 0.0, 1e-3);
  EXPECT_NEAR(r.rendered_force_N[0], 0.0, 0.05);
  // Safe state: the mass stops and the drives hold.
  rig.device->SetSafe();
  const double held = r.position_m[0];
  for (int k = 0; k < 200; ++k) r = rig.Cycle(DofVector::Constant(2, 0.0));
  EXPECT_NEAR(r.position_m[0], held, 1e-4);
  EXPECT_NEAR(rig.device->measured_position_m(0), held, 1e-4) << "the drive holds the joint there";
  rig.device->Deactivate();
  EXPECT_NE(rig.sims[0]->drive_state(), fieldbus::cia402::DriveState::kOperationEnabled);
}

TEST(Admittance, AFaultedDriveIsReportedAndNaNIsRefused) {
  Rig rig(1, 0.5, 5.0);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  Reading r = rig.Cycle(DofVector::Constant(1, 0.0));
  r = rig.Cycle(DofVector::Constant(1, 0.0));
  EXPECT_EQ(r.faults, kFaultNone);
  rig.device->Write(Command::Force(DofVector::Constant(1, std::nan(""))));
  rig.device->Read(r);
  EXPECT_NE(r.faults & kFaultDriver, 0u);
  rig.sims[0]->InjectFault(0x2310);
  rig.Advance(3'000'000);
  r = rig.Cycle(DofVector::Constant(1, 0.0));
  EXPECT_NE(r.faults & kFaultDriver, 0u);
}

// The operator is told what failed, by name: a drive in Fault with the EMCY's code, and a drive that stopped
// answering with its node and stale_after_ms (Device::FaultText, which the event log and Deactivate print).
TEST(Admittance, TheFirstFaultIsNamedWithTheDrivesNodeAndWhatFailed) {
  {
    Rig rig(1, 0.5, 5.0);
    rig.Build();
    rig.device->Configure();
    rig.device->Activate();
    Reading r;
    for (int k = 0; k < 5; ++k) r = rig.Cycle(DofVector::Constant(1, 0.0));
    EXPECT_EQ(rig.device->FaultText(), "");
    rig.sims[0]->InjectFault(0x2310);
    for (int k = 0; k < 5; ++k) r = rig.Cycle(DofVector::Constant(1, 0.0));
    EXPECT_NE(r.faults & kFaultDriver, 0u);
    EXPECT_EQ(rig.device->fault_status(), fieldbus::Cia402Status::kFault);
    const std::string text = rig.device->FaultText();
    EXPECT_EQ(text.rfind("axis 0 (node 1): the drive is in Fault: EMCY 0x2310 ", 0), 0u) << text;
  }
  Rig rig(2, 0.5, 5.0);
  rig.config.axes[1].drive.stale_after_ms = 20.0;
  rig.config.axes[1].drive.heartbeat_timeout_ms = 500.0;
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  Reading r;
  for (int k = 0; k < 5; ++k) r = rig.Cycle(DofVector::Constant(2, 0.0));
  EXPECT_EQ(r.faults, kFaultNone);
  rig.drives_silent = true;
  int cycles = 0;
  for (; cycles < 100 && r.faults == kFaultNone; ++cycles) r = rig.Cycle(DofVector::Constant(2, 0.0));
  EXPECT_NE(r.faults & kFaultCommunication, 0u);
  EXPECT_EQ(rig.device->fault_status(), fieldbus::Cia402Status::kStale);
  EXPECT_EQ(rig.device->FaultText(), "axis 0 (node 1): the drive stopped answering (no TPDO for stale_after_ms), 10 ms")
      << "the first axis found stale is named, with its own stale_after_ms (axis 1's is 20 ms)";
  EXPECT_LE(cycles, 15);
}

// The cycle's SYNC refused while both drives are fine: the fault is the exchange's (kSync, communication), not a
// drive's, and every drive's own frames still went out.
TEST(Admittance, ARefusedSyncIsNamedAsTheSyncNotAsADrive) {
  Rig rig(2, 0.5, 5.0);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  ASSERT_NE(rig.gate, nullptr);
  Reading r;
  for (int k = 0; k < 20; ++k) r = rig.Cycle(DofVector::Constant(2, 0.1));
  EXPECT_EQ(r.faults, kFaultNone);
  EXPECT_EQ(rig.device->fault_source(), AdmittanceFaultSource::kNone);
  rig.gate->refuse_sync = true;
  rig.device->Exchange();
  rig.device->Read(r);
  EXPECT_NE(r.faults & kFaultCommunication, 0u);
  EXPECT_EQ(r.faults & kFaultDriver, 0u);
  EXPECT_EQ(rig.device->fault_source(), AdmittanceFaultSource::kSync);
  EXPECT_EQ(rig.device->fault_axis(), -1);
  EXPECT_STREQ(ToString(rig.device->fault_source()), "SYNC");
  EXPECT_EQ(rig.device->drive(0).counters().write_failures, 0u);  // drive 1's own frames all went out
  // A later drive fault does not rename the first; Activate starts again.
  rig.device->Write(Command::Force(DofVector::Constant(2, std::nan(""))));
  EXPECT_EQ(rig.device->fault_source(), AdmittanceFaultSource::kSync);
  rig.gate->refuse_sync = false;
  rig.device->Deactivate();
  rig.device->Activate();
  EXPECT_EQ(rig.device->fault_source(), AdmittanceFaultSource::kNone);
  rig.device->Write(Command::Force(DofVector::Constant(2, std::nan(""))));
  EXPECT_EQ(rig.device->fault_source(), AdmittanceFaultSource::kCommand);
}

// Velocity mode: the virtual position is anchored to the joint's at the first fresh reading (the joint starts at
// 0.3 rad here, not 0), and the tracking check follows the joint integrating the virtual velocity.
// Torque mode: no virtual mass; the law's force is the drive's torque through the transmission (τ = F · r) and the
// reading is the joint as the drive measures it. The simulated joint (J = 1e-3 kg·m², b = 2e-3 N·m·s/rad,
// τc = 5 mN·m) under F = 1 N at r = 10 mm: τ = 10 mN·m, the net 5 mN·m accelerates it towards ω∞ = 2.5 rad/s with
// J/b = 0.5 s. The stability model is (m_v, b_v) as given, the axis's own J/r² = 10 kg and b/r² = 20 N·s/m, with no
// loop-bandwidth assumption.
TEST(Admittance, TorqueModeSendsTheForceAsTorqueAndReadsTheJoint) {
  Rig rig(1, 10.0, 20.0);
  rig.config.mode = fieldbus::Cia402Mode::kCyclicSynchronousTorque;
  rig.config.position_loop_bandwidth_rad_per_s = 0.0;  // not needed in torque mode
  rig.config.axes[0].transmission_m_per_rad = 0.01;
  const AnalysisModel model = AdmittanceModel(rig.config);
  ASSERT_TRUE(model.applicable) << model.reason;
  EXPECT_EQ(model.mass_kg[0], 10.0);
  EXPECT_EQ(model.damping_Ns_per_m[0], 20.0);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  EXPECT_EQ(rig.sims[0]->mode_of_operation(), 10);
  const DofVector F = DofVector::Constant(1, 1.0);
  Reading r;
  for (int k = 0; k < 500; ++k) {
    r = rig.Cycle(F);
    ASSERT_EQ(r.faults, kFaultNone) << k;
  }
  EXPECT_NEAR(rig.sims[0]->commanded_torque_Nm(), 0.01, 1e-6);
  EXPECT_EQ(r.rendered_force_N[0], 1.0);
  // The reading is the joint (sampled a cycle before it is read: within one cycle of motion, ω · r · 1 ms).
  const double omega = rig.sims[0]->velocity_rad_per_s();
  EXPECT_NEAR(omega, 2.5 * (1.0 - std::exp(-0.5 / 0.5)), 0.05);  // 0.5 s of the first-order response
  EXPECT_NEAR(r.position_m[0], rig.sims[0]->position_rad() * 0.01, std::abs(omega) * 0.01 * 2e-3 + 1e-6);
  EXPECT_NEAR(r.velocity_m_per_s[0], omega * 0.01, 0.01 * 0.05);
  // The safe state sends zero torque.
  rig.device->SetSafe();
  rig.device->Update(rig.config.cycle_period_s);  // the RPDO with τ = 0
  rig.device->Exchange();                         // the SYNC that applies it
  rig.device->Read(r);
  rig.Advance(1'000'000);
  EXPECT_EQ(r.rendered_force_N[0], 0.0);
  EXPECT_EQ(rig.sims[0]->commanded_torque_Nm(), 0.0);
  rig.device->Deactivate();
}

TEST(Admittance, VelocityModeAnchorsTheVirtualPositionToTheJoint) {
  Rig rig(1, 0.5, 5.0, 100.0);
  rig.config.mode = fieldbus::Cia402Mode::kCyclicSynchronousVelocity;
  rig.sims[0]->SetJointState(0.3, 0.0);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  Reading r;
  for (int k = 0; k < 1000; ++k) {
    r = rig.Cycle(DofVector::Constant(1, 1.0));
    ASSERT_EQ(r.faults, kFaultNone) << k;
  }
  const double bound = rig.device->max_tracking_error_m();
  EXPECT_GT(r.position_m[0], 0.3 + 0.5 * Ideal(1.0, 0.5, 5.0, 1.0));
  EXPECT_LT(rig.device->tracking(0).max_error_m, 0.5 * bound);
  EXPECT_NEAR(rig.device->measured_position_m(0), r.position_m[0], 0.5 * bound);
}

// ---- The fixture limit predicted from (m_v, b_v) against the closed loop on the simulated drive ----
//
// The law as the slave's node runs it, slave side, unilateral (the master saturated at x_m: only the slave's loop
// matters, eq. 9 with K_pm = K_dm = 0): F = K_ps (x_m − x_s) − K_ds ẋ_s − K_f max(0, x_s − x_wall), with x_s the
// device's reading and ẋ_s its backward difference (eq. 20), every 1 ms cycle.
struct LimitCase {
  double m_v = 2.0, b_v = 20.0, kps = 600.0, kds = 2.0;
};

analysis::StabilityLimit PredictedLimit(const LimitCase& c) {
  analysis::SampledTeleoperator system;
  system.rate_hz = 1000.0;
  system.slave.mass_kg = c.m_v;
  system.slave.damping_Ns_per_m = c.b_v;
  system.gains.kps_N_per_m = c.kps;
  system.gains.kds_Ns_per_m = c.kds;
  system.unilateral = true;
  system.peer_delay_samples = 1;
  return analysis::FindMaxStableStiffness(system, analysis::FixtureSide::kSlave,
                                          analysis::MakeHumanGrid(analysis::DefaultFingerBounds(), 2));
}

/// The position ripple (std dev about the mean) of the law's x_s in the second quarter and the last quarter of a run.
struct Ripple {
  double early = 0.0, late = 0.0;
  double follow = 0.0;   ///< Largest |joint − virtual mass two cycles earlier| in the last half, m.
  bool faulted = false;  ///< The device reported a fault (the tracking check) in the run.
  bool Decays() const { return late < early; }
};
/// What the law reads as x_s: the device's reading (AdmittanceDevice::Read, what the slave's node feeds the law: the
/// virtual mass), the drive's measured position (what Read reported before: the virtual mass two cycles late through
/// the drive), or the virtual mass two cycles late with no drive in the loop (the transport alone).
enum class Feedback { kReading, kDriveMeasured, kVirtualTwoCyclesLate };
Ripple RunAtStiffness(const LimitCase& c, double k, double bandwidth, Feedback feedback, int cycles) {
  fieldbus::SimulatedJointConfig joint;
  const fieldbus::SimulatedLoopConfig loops = fieldbus::LoopsForBandwidth(bandwidth, joint);
  Rig rig(1, c.m_v, c.b_v, bandwidth, &loops, &joint);
  rig.Build();
  rig.device->Configure();
  rig.device->Activate();
  const double wall = 0.0, xm = 0.01;  // the master 10 mm inside the region: the slave pushed into the fixture
  Reading r;
  double prev = 0.0;
  std::vector<double> xs, xv;
  Ripple out;
  for (int n = 0; n < cycles; ++n) {
    rig.device->Exchange();
    rig.device->Read(r);
    out.faulted = out.faulted || r.faults != kFaultNone;
    const double x = feedback == Feedback::kReading         ? r.position_m[0]
                     : feedback == Feedback::kDriveMeasured ? rig.device->measured_position_m(0)
                     : n >= 2                               ? xv[static_cast<std::size_t>(n - 2)]
                                                            : 0.0;
    const double v = n == 0 ? 0.0 : (x - prev) * 1e3;
    prev = x;
    if (n >= cycles / 2 && n >= 2) {
      out.follow =
          std::max(out.follow, std::abs(rig.device->measured_position_m(0) - xv[static_cast<std::size_t>(n - 2)]));
    }
    xv.push_back(rig.device->axis_model(0).position_m());
    const double f = c.kps * (xm - x) - c.kds * v - k * std::max(0.0, x - wall);
    rig.device->Write(Command::Force(DofVector::Constant(1, f)));
    rig.device->Update(1e-3);
    rig.Advance(1'000'000);
    xs.push_back(x);
  }
  const auto sd = [&](int from, int to) {
    double mean = 0.0;
    for (int i = from; i < to; ++i) mean += xs[static_cast<std::size_t>(i)];
    mean /= to - from;
    double var = 0.0;
    for (int i = from; i < to; ++i) var += std::pow(xs[static_cast<std::size_t>(i)] - mean, 2);
    return std::sqrt(var / (to - from));
  };
  out.early = sd(cycles / 4, cycles / 2);
  out.late = sd(3 * cycles / 4, cycles);
  return out;
}

/// The simulated limit: bisection in [lo, hi] N/m on "the ripple decays" (2 s runs, last quarter against the second) to
/// 2 %.
double SimulatedLimit(const LimitCase& c, double bandwidth, double lo, double hi,
                      Feedback feedback = Feedback::kReading) {
  while (hi - lo > 0.02 * lo) {
    const double mid = 0.5 * (lo + hi);
    (RunAtStiffness(c, mid, bandwidth, feedback, 2000).Decays() ? lo : hi) = mid;
  }
  return lo;
}

// The device as shipped, on a drive as labs tune it: position loop 2000 rad/s (318 Hz). The predicted limit
// K* = 43.4 kN/m puts the virtual mass at sqrt(K*/m_v) = 147 rad/s, so the loop is 13.6 times faster (ratio 10
// asked): the model applies. The law closes its loop on the device's reading, the virtual mass's state, which is the
// loop the analysis models: 0.9× settles, 1.1× keeps oscillating (the analysis' tolerance is 0.1 %; 0.9× and 1.1×
// are far outside it), the bisection finds K* within its own 2 % steps (3 % asked), the joint follows the virtual mass
// (two cycles of transport) within 2 % of the 10 mm push and the tracking check never trips. Had the law read the
// drive's measured position (the virtual mass two cycles late: RPDO applied at the next SYNC, TPDO read a cycle
// later, a delay the sampled model does not have) the limit would be several times lower — why Read does not report
// it. docs/cia402.md, "Admittance backend".
TEST(AdmittanceLimit, TheDeviceAsShippedMeetsThePredictionOnAFastDrive) {
  const LimitCase c;
  const analysis::StabilityLimit limit = PredictedLimit(c);
  const double k_star = limit.max_stable_stiffness_N_per_m;
  ASSERT_GT(k_star, 0.0);
  constexpr double kFast = 2000.0;
  AdmittanceConfig config;
  config.virtual_mass_kg = DofVector::Constant(1, c.m_v);
  config.virtual_damping_Ns_per_m = DofVector::Constant(1, c.b_v);
  config.position_loop_bandwidth_rad_per_s = kFast;
  config.max_stiffness_N_per_m = k_star;
  const AnalysisModel model = AdmittanceModel(config);
  ASSERT_TRUE(model.applicable) << model.reason;
  const double ratio = kFast / std::sqrt(k_star / c.m_v);
  EXPECT_GT(ratio, 10.0);

  const Ripple below = RunAtStiffness(c, 0.9 * k_star, kFast, Feedback::kReading, 4000);
  const Ripple above = RunAtStiffness(c, 1.1 * k_star, kFast, Feedback::kReading, 4000);
  EXPECT_LT(below.late, 0.6 * below.early) << "0.9x did not settle";
  EXPECT_GT(above.late, 0.95 * above.early) << "1.1x did not keep oscillating";
  EXPECT_GT(above.late, 2e-5);
  EXPECT_LT(below.follow, 0.02 * 0.01) << "the joint does not follow the virtual mass";
  EXPECT_FALSE(below.faulted) << "a following drive tripped the tracking check";

  // The bisection's criterion (2 % steps on "the ripple decays") sets this tolerance, not the analysis' 0.1 %.
  const double shipped = SimulatedLimit(c, kFast, 0.5 * k_star, 1.5 * k_star, Feedback::kReading);
  EXPECT_NEAR(shipped, k_star, 0.03 * k_star);
  const double measured = SimulatedLimit(c, kFast, 0.0, 0.5 * k_star, Feedback::kDriveMeasured);
  const double transport = SimulatedLimit(c, kFast, 0.0, 0.5 * k_star, Feedback::kVirtualTwoCyclesLate);
  std::printf(
      "admittance limit: predicted %.0f N/m; loop %.0f rad/s = %.1f x sqrt(K*/m_v); the device's reading (virtual "
      "state): 0.9x ripple %.2g -> %.2g m, 1.1x %.2g -> %.2g m, bisection %.0f N/m (%.3f x); joint - virtual(2 cycles "
      "earlier) <= %.3f mm (tracking bound %.2f mm); had the law read the drive's measured position: %.0f N/m (%.2f "
      "x); the virtual state two cycles late, no drive: %.0f N/m (%.2f x)\n",
      k_star, kFast, ratio, below.early, below.late, above.early, above.late, shipped, shipped / k_star,
      below.follow * 1e3, DefaultMaxTrackingError(config) * 1e3, measured, measured / k_star, transport,
      transport / k_star);
  EXPECT_LT(measured, 0.3 * k_star) << "the drive's measured position no longer lowers the limit";
  EXPECT_NEAR(transport, measured, 0.25 * measured) << "the two cycles of transport do not explain that limit";
}

// A slow drive (250 rad/s, the shipped tuning): sqrt(K*/m_v) = 147 rad/s is not 10 times below it, and the model says
// "not applicable". The law on the virtual state is still the analysed loop, but the joint no longer follows the
// virtual mass: near K* the joint's error is many times the fast drive's, and the tracking check faults the pair.
TEST(AdmittanceLimit, ASlowDriveIsNotApplicableAndDoesNotFollow) {
  const LimitCase c;
  const double k_star = PredictedLimit(c).max_stable_stiffness_N_per_m;
  constexpr double kSlow = 250.0;
  AdmittanceConfig config;
  config.virtual_mass_kg = DofVector::Constant(1, c.m_v);
  config.virtual_damping_Ns_per_m = DofVector::Constant(1, c.b_v);
  config.position_loop_bandwidth_rad_per_s = kSlow;
  config.max_stiffness_N_per_m = k_star;
  const AnalysisModel model = AdmittanceModel(config);
  EXPECT_FALSE(model.applicable);
  EXPECT_NE(model.reason.find("is not 10 times faster than the virtual mass on the stiffest spring"), std::string::npos)
      << model.reason;
  const Ripple slow = RunAtStiffness(c, 0.9 * k_star, kSlow, Feedback::kReading, 2000);
  const Ripple fast = RunAtStiffness(c, 0.9 * k_star, 2000.0, Feedback::kReading, 2000);
  std::printf(
      "admittance at 0.9 K*: joint - virtual(2 cycles earlier) %.3f mm with a %.0f rad/s loop (faulted %d), "
      "%.3f mm with 2000 rad/s (faulted %d)\n",
      slow.follow * 1e3, kSlow, slow.faulted ? 1 : 0, fast.follow * 1e3, fast.faulted ? 1 : 0);
  EXPECT_GT(slow.follow, 3.0 * fast.follow);
}

// The tracking check: F = 1 N on m_v = 0.5 kg, b_v = 5 N·s/m moves the virtual mass along the closed form; a drive
// whose joint is blocked at 0 reads 0, so the error is the virtual position two cycles earlier. It crosses the bound
// at a cycle k0 computed from the closed form, and kFaultDriver comes exactly tracking_error_cycles readings later;
// then the safe state holds the virtual mass where the joint is. The same push on a free joint never faults.
TEST(Admittance, ADriveThatDoesNotFollowFaultsWithinThePersistence) {
  constexpr int kPersist = 5;
  for (const bool blocked : {true, false}) {
    Rig rig(1, 0.5, 5.0, 100.0);
    rig.config.tracking_error_cycles = kPersist;
    rig.Build();
    rig.device->Configure();
    rig.device->Activate();
    const double bound = rig.device->max_tracking_error_m();
    EXPECT_NEAR(bound, 2.0 * (0.5 / 100.0 + 0.5 * 1e-3), 1e-12) << "DefaultMaxTrackingError";
    // Read k reports Ideal(k ms) (the reading test above); the check at Read k compares with Read k−2's report.
    int k0 = 0;
    while (Ideal(1.0, 0.5, 5.0, (k0 - 2) * 1e-3) <= bound) ++k0;
    int faulted_at = -1;
    Reading r;
    for (int k = 0; k < 1000 && faulted_at < 0; ++k) {
      if (blocked) rig.sims[0]->SetJointState(0.0, 0.0);
      rig.device->Exchange();
      rig.device->Read(r);
      if (r.faults != kFaultNone) {
        faulted_at = k;
        break;
      }
      rig.device->Write(Command::Force(DofVector::Constant(1, 1.0)));
      rig.device->Update(1e-3);
      rig.Advance(1'000'000);
    }
    if (!blocked) {
      EXPECT_EQ(faulted_at, -1) << "a following drive faulted";
      EXPECT_LT(rig.device->tracking(0).max_error_m, 0.5 * bound);
      EXPECT_EQ(rig.device->tracking(0).faults, 0u);
      continue;
    }
    std::printf("blocked joint: error beyond %.1f mm from reading %d, fault at reading %d (persistence %d)\n",
                bound * 1e3, k0, faulted_at, kPersist);
    EXPECT_EQ(faulted_at, k0 + kPersist - 1);
    EXPECT_NE(r.faults & kFaultDriver, 0u);
    EXPECT_EQ(rig.device->tracking(0).faults, 1u);
    EXPECT_NEAR(rig.device->measured_position_m(0), 0.0, 1e-5);
    rig.device->SetSafe();
    for (int k = 0; k < 5; ++k) {
      rig.sims[0]->SetJointState(0.0, 0.0);
      r = rig.Cycle(DofVector::Zero(1));
    }
    EXPECT_NEAR(r.position_m[0], 0.0, 1e-5) << "the safe state holds the virtual mass where the joint is";
    EXPECT_EQ(r.faults, kFaultNone);
  }
}

TEST(Admittance, ConfigErrorsNameTheKey) {
  AdmittanceConfig c;
  c.dof = 1;
  c.virtual_mass_kg = DofVector::Constant(1, 0.0);
  c.virtual_damping_Ns_per_m = DofVector::Constant(1, 1.0);
  c.axes.resize(1);
  EXPECT_THROW(AdmittanceDevice d(c), Error);
  c.virtual_mass_kg[0] = 1.0;
  c.mode = static_cast<fieldbus::Cia402Mode>(3);  // profile velocity: not a cyclic synchronous mode
  try {
    AdmittanceDevice d(c);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mode must be position, velocity or torque"), std::string::npos) << e.what();
  }
  c.mode = fieldbus::Cia402Mode::kCyclicSynchronousPosition;
  c.tracking_error_cycles = 0;
  try {
    AdmittanceDevice d(c);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tracking_error_cycles must be >= 1"), std::string::npos) << e.what();
  }
  c.tracking_error_cycles = 10;
  c.max_tracking_error_m = std::nan("");
  EXPECT_THROW(AdmittanceDevice d(c), Error);
  EXPECT_NE(FindDevice("admittance"), nullptr);
}

}  // namespace
}  // namespace teleop::device
