// Encode/decode/CRC cost per sample. Prints ns per call; not a test.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/crc.hpp"

namespace {

teleop::proto::SampleMessage MakeMessage(int dof) {
  teleop::proto::SampleMessage m;
  m.dof = static_cast<std::uint8_t>(dof);
  for (int i = 0; i < dof; ++i) {
    m.position_m[i] = 0.01 * i;
    m.velocity_m_per_s[i] = -0.1 * i;
    m.force_N[i] = 1.5 * i;
  }
  return m;
}

void BM_Encode(benchmark::State& state) {
  teleop::proto::SampleMessage m = MakeMessage(static_cast<int>(state.range(0)));
  std::array<std::uint8_t, teleop::proto::kMaxEncodedSampleBytes> buffer{};
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(teleop::proto::EncodeSample(m, buffer));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_Encode)->Arg(1)->Arg(2)->Arg(3)->Arg(6)->Arg(7)->Arg(12);

void BM_Decode(benchmark::State& state) {
  const teleop::proto::SampleMessage m = MakeMessage(static_cast<int>(state.range(0)));
  std::array<std::uint8_t, teleop::proto::kMaxEncodedSampleBytes> buffer{};
  const std::size_t size = teleop::proto::EncodeSample(m, buffer);
  teleop::proto::SampleMessage out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(teleop::proto::DecodeSample(std::span(buffer).first(size), out));
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_Decode)->Arg(1)->Arg(2)->Arg(3)->Arg(6)->Arg(7)->Arg(12);

void BM_Crc32c(benchmark::State& state) {
  std::array<std::uint8_t, 180> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 7);
  for (auto _ : state) benchmark::DoNotOptimize(teleop::proto::Crc32c(bytes));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(bytes.size()));
}
BENCHMARK(BM_Crc32c);

}  // namespace

BENCHMARK_MAIN();
