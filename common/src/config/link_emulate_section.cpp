// The `link.emulate` section (docs/link-emulation.md, docs/configuration.md): an emulated bad network on the
// receive side of the process's link.

#include <string>
#include <vector>

#include "sections.hpp"

namespace teleop::config::sections {

namespace {

double Probability(const Field& f) { return InRange(f, 0.0, 1.0, "(probability)"); }

void ParseBurst(const Field& f, transport::BurstLossConfig& burst) {
  const Map map(f, {"enter_probability", "exit_probability", "loss_probability"});
  burst.enter_probability = Probability(map.Required("enter_probability"));
  const Field exit = map.Required("exit_probability");
  burst.exit_probability = Probability(exit);
  if (burst.exit_probability <= 0.0) exit.Fail("must be > 0: with 0 a burst never ends");
  if (auto v = map.Optional("loss_probability")) burst.loss_probability = Probability(*v);
}

void ParseOutages(const Field& f, std::vector<transport::Outage>& outages) {
  if (!f.IsSequence()) f.Fail("must be a list of [start_s, duration_s] pairs, e.g. [[1.0, 0.1], [2.5, 0.5]]");
  for (const Field& item : f.AsList()) {
    if (!item.IsSequence() || item.AsList().size() != 2) {
      item.Fail("must be a pair [start_s, duration_s] (seconds since the link opened, and > 0 s long)");
    }
    const std::vector<Field> pair = item.AsList();
    transport::Outage o;
    o.start_s = InRange(pair[0], 0.0, 1e6, "s (start since the link opened)");
    o.duration_s = InRange(pair[1], 1e-6, 1e6, "s (duration)");
    outages.push_back(o);
  }
}

void ParseDelaySteps(const Field& f, std::vector<transport::DelayStep>& steps) {
  if (!f.IsSequence()) {
    f.Fail("must be a list of {at_s, delay_ms} maps, e.g. [{at_s: 3, delay_ms: 60}, {at_s: 8, delay_ms: 1}]");
  }
  for (const Field& item : f.AsList()) {
    const Map map(item, {"at_s", "delay_ms"});
    transport::DelayStep step;
    const Field at = map.Required("at_s");
    step.at_s = InRange(at, 0.0, 1e6, "s (since the link opened)");
    step.delay_s = InRange(map.Required("delay_ms"), 0.0, 10000.0, "ms") * 1e-3;
    if (!steps.empty() && step.at_s <= steps.back().at_s) at.Fail("the steps must be in ascending order of at_s");
    steps.push_back(step);
  }
}

}  // namespace

void ParseLinkEmulate(const Field& f, double rate_hz, link::LinkConfig::Emulation& emulate) {
  const Map map(
      f, {"enabled", "seed", "delay_ms", "jitter_ms", "loss_probability", "burst", "duplicate_probability",
          "reorder_probability", "corrupt_probability", "bandwidth_bit_per_s", "queue_ms", "outages", "delay_steps"});
  transport::ImpairmentConfig& c = emulate.impairments;
  emulate.enabled = true;
  if (auto v = map.Optional("enabled")) emulate.enabled = v->AsBool();
  if (auto v = map.Optional("seed")) emulate.seed = static_cast<std::uint64_t>(IntInRange(*v, 0, 2147483647));
  if (auto v = map.Optional("delay_ms")) c.delay_s = InRange(*v, 0.0, 10000.0, "ms") * 1e-3;
  if (auto v = map.Optional("jitter_ms")) c.jitter_s = InRange(*v, 0.0, 10000.0, "ms") * 1e-3;
  if (auto v = map.Optional("loss_probability")) c.loss_probability = Probability(*v);
  if (auto v = map.Optional("burst")) ParseBurst(*v, c.burst);
  if (auto v = map.Optional("duplicate_probability")) c.duplicate_probability = Probability(*v);
  if (auto v = map.Optional("reorder_probability")) {
    c.reorder_probability = Probability(*v);
    const double period_ms = 1000.0 / rate_hz;
    if (c.reorder_probability > 0.0 && c.delay_s * 1e3 <= period_ms) {
      v->Fail("needs link.emulate.delay_ms > one loop period (" + Num(period_ms) + " ms at rate_hz " + Num(rate_hz) +
              "): a sample can only overtake one still in flight; delay_ms is " + Num(c.delay_s * 1e3));
    }
  }
  if (auto v = map.Optional("corrupt_probability")) c.corrupt_probability = Probability(*v);
  if (auto v = map.Optional("bandwidth_bit_per_s")) c.bandwidth_bit_per_s = InRange(*v, 1000.0, 1e11, "bit/s");
  if (auto v = map.Optional("queue_ms")) {
    if (c.bandwidth_bit_per_s <= 0.0) v->Fail("only with link.emulate.bandwidth_bit_per_s (the bandwidth queue)");
    c.queue_limit_s = InRange(*v, 0.0, 10000.0, "ms") * 1e-3;
  }
  if (auto v = map.Optional("outages")) ParseOutages(*v, c.outages);
  if (auto v = map.Optional("delay_steps")) ParseDelaySteps(*v, c.delay_steps);
}

}  // namespace teleop::config::sections
