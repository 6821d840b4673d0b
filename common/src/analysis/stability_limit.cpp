#include "teleop/analysis/stability_limit.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "teleop/analysis/damping_ratio.hpp"
#include "teleop/analysis/discrete_model.hpp"
#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

// Runs scan(t) for t = 0..threads-1: on the calling thread when threads == 1, else one thread each.
template <typename ScanFn>
void RunOnThreads(int threads, const ScanFn& scan) {
  if (threads == 1) {
    scan(0);
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads));
  for (int t = 0; t < threads; ++t) pool.emplace_back(scan, t);
  for (std::thread& thread : pool) thread.join();
}

// |z| above 1 by more than this is unstable; the margin keeps a marginal free-mass mode (z = 1 exactly, e.g. a
// slave with no position coupling) from being called unstable by rounding.
constexpr double kUnstableMargin = 1e-9;
// The bisection starts its bracket here when the passivity bound gives nothing better.
constexpr double kFirstGuess_N_per_m = 1000.0;
// Bisection steps (over one operator or the set) before giving up; far more than 0.1 % from 1e9 N/m needs.
constexpr int kMaxSteps = 2000;
// Rounds of single-operator refinement before plain bisection over the set.
constexpr int kOperatorRounds = 3;

// The operator-dependent part of the model, computed once per search: the discretized master+operator blocks.
struct PreparedSystem {
  SampledTeleoperator system;
  FixtureSide side = FixtureSide::kMaster;
  std::vector<ZohBlock> master_blocks;
  ZohBlock slave;
  bool lines = false;  ///< A delay over one sample: the delay-line model (dynamic size, O(n³) per operator).
  /// Operators per thread below which a scan stays on one thread (an 8×8 model costs ~µs, a delay-line one ~ms).
  int min_per_thread() const noexcept { return lines ? 2 : 64; }
};

// `system` as the model should see it (callers apply EffectiveGains when a side is being searched).
PreparedSystem Prepare(const SampledTeleoperator& system, FixtureSide side, std::span<const HumanModel> humans) {
  Validate(system);
  if (humans.empty()) throw Error("stability analysis: the operator set is empty (give a grid or a bounds file)");
  PreparedSystem prepared;
  prepared.system = system;
  prepared.side = side;
  prepared.master_blocks.reserve(humans.size());
  for (const HumanModel& human : humans) {
    Validate(human);
    prepared.master_blocks.push_back(DiscretizeMasterWithHuman(prepared.system, human));
  }
  prepared.slave = DiscretizeSlave(prepared.system);
  prepared.lines = NeedsDelayLines(prepared.system);
  return prepared;
}

double Radius(const PreparedSystem& p, int index, double stiffness) {
  SampledTeleoperator system = p.system;
  system.gains.fixture(p.side) = stiffness;
  const ZohBlock& master = p.master_blocks[static_cast<std::size_t>(index)];
  if (p.lines) return SpectralRadius(AssembleDelayedStateMatrix(system, master, p.slave));
  return SpectralRadius(AssembleStateMatrix(system, master, p.slave));
}

bool IsUnstable(const PreparedSystem& p, int index, double stiffness) {
  return Radius(p, index, stiffness) > 1.0 + kUnstableMargin;
}

struct Probe {
  int unstable = -1;       ///< An operator unstable at the probed stiffness, or -1 when all are stable.
  int most_critical = -1;  ///< When all are stable: the operator of largest |z| (likely the first to go unstable).
};

// Looks for an operator unstable at `stiffness`, trying `first` before the others and stopping at the first one
// found. Splits the set over `threads` threads (interleaved), each stopping as soon as any finds one.
Probe FindUnstableOperator(const PreparedSystem& p, double stiffness, int first, int threads, int& evaluated) {
  const int n = static_cast<int>(p.master_blocks.size());
  Probe probe;
  if (first >= 0 && first < n) {
    ++evaluated;
    if (IsUnstable(p, first, stiffness)) {
      probe.unstable = first;
      return probe;
    }
  }
  threads = std::clamp(threads, 1, std::max(1, n / p.min_per_thread()));
  std::atomic<int> found{-1};
  std::vector<int> counts(static_cast<std::size_t>(threads), 0);
  std::vector<std::pair<double, int>> critical(static_cast<std::size_t>(threads), {-1.0, -1});
  auto scan = [&](int t) {
    auto& best = critical[static_cast<std::size_t>(t)];
    for (int i = t; i < n && found.load(std::memory_order_relaxed) < 0; i += threads) {
      ++counts[static_cast<std::size_t>(t)];
      const double radius = Radius(p, i, stiffness);
      if (radius > 1.0 + kUnstableMargin) {
        int expected = -1;
        found.compare_exchange_strong(expected, i);
        return;
      }
      if (radius > best.first) best = {radius, i};
    }
  };
  RunOnThreads(threads, scan);
  for (int c : counts) evaluated += c;
  probe.unstable = found.load();
  if (probe.unstable < 0) probe.most_critical = std::max_element(critical.begin(), critical.end())->second;
  return probe;
}

struct Scan {
  double max_radius = 0.0;
  int index = -1;  ///< The operator of largest |z|.
};

// |z| of every operator at `stiffness`, no early exit; split over `threads` threads.
Scan ScanAll(const PreparedSystem& p, double stiffness, int threads, int& evaluated) {
  const int n = static_cast<int>(p.master_blocks.size());
  threads = std::clamp(threads, 1, std::max(1, n / p.min_per_thread()));
  std::vector<Scan> partial(static_cast<std::size_t>(threads));
  auto scan = [&](int t) {
    Scan& best = partial[static_cast<std::size_t>(t)];
    for (int i = t; i < n; i += threads) {
      const double radius = Radius(p, i, stiffness);
      if (best.index < 0 || radius > best.max_radius) best = {radius, i};
    }
  };
  RunOnThreads(threads, scan);
  evaluated += n;
  return *std::max_element(partial.begin(), partial.end(),
                           [](const Scan& a, const Scan& b) { return a.max_radius < b.max_radius; });
}

// Fig. 5 over the prepared operator set, with the fixture of p.side at `stiffness`.
WorstCase Worst(const PreparedSystem& p, std::span<const HumanModel> humans, double stiffness, int threads) {
  SampledTeleoperator system = p.system;
  system.gains.fixture(p.side) = stiffness;
  const int n = static_cast<int>(humans.size());
  threads = std::clamp(threads, 1, std::max(1, n / p.min_per_thread()));
  struct Partial {
    double min_zeta = 2.0;
    double max_radius = 0.0;
    int index = 0;
  };
  std::vector<Partial> partial(static_cast<std::size_t>(threads));
  auto scan = [&](int t) {
    Partial& best = partial[static_cast<std::size_t>(t)];
    for (int i = t; i < n; i += threads) {
      const ZohBlock& master = p.master_blocks[static_cast<std::size_t>(i)];
      const ModalSummary modes =
          p.lines ? AnalyzeEigenvalues(AssembleDelayedStateMatrix(system, master, p.slave), system.period_s())
                  : AnalyzeEigenvalues(AssembleStateMatrix(system, master, p.slave), system.period_s());
      best.max_radius = std::max(best.max_radius, modes.spectral_radius);
      if (modes.min_damping_ratio < best.min_zeta) {
        best.min_zeta = modes.min_damping_ratio;
        best.index = i;
      }
    }
  };
  RunOnThreads(threads, scan);
  WorstCase worst;
  worst.min_damping_ratio = 2.0;
  for (const Partial& part : partial) {
    worst.spectral_radius = std::max(worst.spectral_radius, part.max_radius);
    if (part.min_zeta < worst.min_damping_ratio) {
      worst.min_damping_ratio = part.min_zeta;
      worst.human = humans[static_cast<std::size_t>(part.index)];
    }
  }
  worst.models_evaluated = n;
  return worst;
}

int ResolveThreads(int requested) noexcept {
  if (requested > 0) return requested;
  return static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 8u));
}

}  // namespace

WorstCase EvaluateWorstCase(const SampledTeleoperator& system, std::span<const HumanModel> humans) {
  const PreparedSystem prepared = Prepare(system, FixtureSide::kMaster, humans);
  return Worst(prepared, humans, system.gains.master_fixture_N_per_m, ResolveThreads(0));
}

double PassivityBound(const SampledTeleoperator& system, FixtureSide side) noexcept {
  const LawGains g = EffectiveGains(system, side);
  const double t = system.period_s();
  double b = 0.0;
  double kp = 0.0;
  double virtual_damping = 0.0;
  if (side == FixtureSide::kMaster) {
    b = system.master.damping_Ns_per_m;
    kp = g.kpm_N_per_m;
    virtual_damping = g.kdm_Ns_per_m + g.kvm_Ns_per_m;
  } else {
    b = system.slave.damping_Ns_per_m;
    kp = g.kps_N_per_m;
    virtual_damping = g.kds_Ns_per_m + g.kvs_Ns_per_m;
  }
  return std::max(0.0, 2.0 * (b - std::abs(virtual_damping)) / t - kp);
}

StabilityLimit FindMaxStableStiffness(const SampledTeleoperator& system, FixtureSide side,
                                      std::span<const HumanModel> humans, const LimitOptions& options) {
  if (!(options.relative_tolerance > 0.0) || !(options.max_stiffness_N_per_m > 0.0)) {
    throw Error("stability analysis: relative_tolerance and max_stiffness_N_per_m must be > 0");
  }
  SampledTeleoperator effective = system;
  effective.gains = EffectiveGains(system, side);
  const PreparedSystem prepared = Prepare(effective, side, humans);
  const int threads = ResolveThreads(options.threads);
  StabilityLimit result;
  result.passivity_bound_N_per_m = PassivityBound(system, side);

  int evaluated = 0;
  int last_unstable = 0;
  int limiting = -1;
  int critical = -1;  // the operator closest to instability at `lo`
  auto probe = [&](double stiffness) {
    const Probe found = FindUnstableOperator(prepared, stiffness, last_unstable, threads, evaluated);
    if (found.unstable >= 0) last_unstable = found.unstable;
    if (found.unstable < 0) critical = found.most_critical;
    ++result.bisection_steps;
    return found.unstable;
  };

  double lo = 0.0;
  double hi = 0.0;
  // The limit is the first stiffness, counting up from 0, at which an operator goes unstable: everything below it
  // is stable. So 0 (the coupling alone, the device in free space) is probed first. Over a delay of a few samples
  // the stable stiffnesses need not start at 0 nor be one interval (the delayed coupling can be unstable alone and
  // stable with a stiff fixture, docs/stability.md "Stiffness windows"): a stable guess above 0 says nothing of
  // the stiffnesses below it.
  const int at_zero = probe(0.0);
  if (at_zero >= 0) {
    result.unstable_without_fixture = true;
    limiting = at_zero;
  } else {
    // Bracket: from a first guess, grow ×4 while stable.
    hi = std::min(options.max_stiffness_N_per_m, std::max(kFirstGuess_N_per_m, result.passivity_bound_N_per_m));
    limiting = probe(hi);
    while (limiting < 0) {
      lo = hi;
      if (hi >= options.max_stiffness_N_per_m || result.bisection_steps > kMaxSteps) break;
      hi = std::min(options.max_stiffness_N_per_m, hi * 4.0);
      limiting = probe(hi);
    }
    // With delay lines, walk [0, hi] up in steps of hi / scan_points: the first unstable step is the bracket's
    // upper end, the step before its lower (an unstable window between 0 and the first guess, or between two
    // stable probes of the growth, would otherwise be bisected past). Windows narrower than a step can be missed.
    if (prepared.lines && limiting >= 0 && options.delay_scan_points > 1) {
      const double top = hi;
      double below = 0.0;
      for (int i = 1; i < options.delay_scan_points; ++i) {
        const double stiffness = top * i / options.delay_scan_points;
        const int index = probe(stiffness);
        if (index >= 0) {
          hi = stiffness;
          limiting = index;
          break;
        }
        below = stiffness;
      }
      lo = below;
    }
  }
  if (!result.unstable_without_fixture) {
    // Refine. Bisect on the limiting operator alone (one model per step) to half the tolerance, then verify the
    // whole set just below that operator's own limit; an operator unstable there becomes the limiting one. This
    // usually costs one or two passes over the set instead of one per step. When operators keep taking over (the
    // slave side at high rates, where the limit hardly depends on the operator), fall back to plain bisection
    // over the set. Invariant: `lo` is stable for every operator, `hi` unstable for `limiting`.
    const double tolerance = options.relative_tolerance;
    auto converged = [&] { return hi - lo <= tolerance * std::max(lo, 1e-6) || result.bisection_steps >= kMaxSteps; };
    // Start with the operator that was closest to instability at `lo`, if it is unstable at `hi`.
    if (limiting >= 0 && critical >= 0 && critical != limiting) {
      ++evaluated;
      if (IsUnstable(prepared, critical, hi)) limiting = critical;
    }
    for (int round = 0; round < kOperatorRounds && limiting >= 0 && !converged(); ++round) {
      double operator_lo = lo;
      double operator_hi = hi;
      while (operator_hi - operator_lo > 0.5 * tolerance * std::max(operator_lo, 1e-6) &&
             result.bisection_steps < kMaxSteps) {
        const double mid = 0.5 * (operator_lo + operator_hi);
        ++evaluated;
        ++result.bisection_steps;
        if (IsUnstable(prepared, limiting, mid)) {
          operator_hi = mid;
        } else {
          operator_lo = mid;
        }
      }
      hi = operator_hi;
      // Full pass: near the limit the operator of largest |z| is the one whose own limit is lowest.
      const Scan scan = ScanAll(prepared, operator_lo, threads, evaluated);
      ++result.bisection_steps;
      if (scan.max_radius > 1.0 + kUnstableMargin) {
        hi = operator_lo;
        limiting = scan.index;
      } else {
        lo = operator_lo;
      }
    }
    while (limiting >= 0 && !converged()) {
      const double mid = 0.5 * (lo + hi);
      const int index = probe(mid);
      if (index >= 0) {
        hi = mid;
        limiting = index;
      } else {
        lo = mid;
      }
    }
  }
  result.max_stable_stiffness_N_per_m = lo;
  result.min_unstable_stiffness_N_per_m = hi;
  if (limiting >= 0) result.limiting_human = humans[static_cast<std::size_t>(limiting)];
  const WorstCase worst = Worst(prepared, humans, lo, threads);
  result.worst_damping_ratio = worst.min_damping_ratio;
  result.worst_human = worst.human;
  result.models_evaluated = evaluated + worst.models_evaluated;
  return result;
}

}  // namespace teleop::analysis
