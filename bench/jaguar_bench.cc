// Cost of the Jaguar protocol codecs (drivers/motor) per message: decoding and parsing a V2
// 0x7C sensor frame, encoding the PWM frame, parsing ASCII report and IMU lines. The boards
// send ~30 frames or ~50 lines a second, so anything in microseconds is noise on the link
// thread; this guards against a regression by orders of magnitude.

#include <benchmark/benchmark.h>

#include "drivers/motor/jaguar_ascii_protocol.h"
#include "drivers/motor/jaguar_v2_protocol.h"

namespace tsc {
namespace {

void BM_JaguarV2DecodeCustomSensor(benchmark::State& state) {
  using namespace jaguar_v2;
  CustomSensor s;
  s.analog[1] = 3000;
  s.ch3_encoder = 12345;
  s.ch4_encoder = 54321;
  const auto bytes = Encode(
      {kDestPc, 0, static_cast<uint8_t>(FrameType::kCustomSensor), SerializeCustomSensor(s)});
  DecodeCounters counters;
  for (auto _ : state) {
    const auto frame = Decode(bytes, counters);
    const auto parsed = ParseCustomSensor(frame->data);
    benchmark::DoNotOptimize(parsed->battery_volts());
  }
}
BENCHMARK(BM_JaguarV2DecodeCustomSensor);

void BM_JaguarV2EncodePwm(benchmark::State& state) {
  using namespace jaguar_v2;
  PwmChannels pwm = AllStop();
  pwm[3] = 20000;
  for (auto _ : state) benchmark::DoNotOptimize(EncodePwmAll(pwm));
}
BENCHMARK(BM_JaguarV2EncodePwm);

void BM_JaguarAsciiParseLines(benchmark::State& state) {
  using namespace jaguar_ascii;
  const std::string encoder = "MM0 C=123456:-654321\r\n";
  const std::string imu = "#1234,YAW,1.2345,GYRO,0,0,0.5,ACC,0,0,9.81,COMP,0.2,0,0.4\r\n";
  for (auto _ : state) {
    benchmark::DoNotOptimize(ParseReply(encoder));
    benchmark::DoNotOptimize(ParseReply(imu));
  }
  state.counters["lines/s"] = benchmark::Counter(2.0 * static_cast<double>(state.iterations()),
                                                 benchmark::Counter::kIsRate);
}
BENCHMARK(BM_JaguarAsciiParseLines);

}  // namespace
}  // namespace tsc
