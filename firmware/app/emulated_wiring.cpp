#include "firmware/app/emulated_wiring.hpp"

#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware {

hal::Status SimTimeCanBus::receive(hal::CanRxFrame& out) {
  for (;;) {
    const hal::Status s = inner_.receive(out);
    if (s != hal::Status::kOk) return s;
    std::int64_t t = 0;
    if (out.error || !parse_sim_time_frame(out.frame, t)) return s;
    ++time_frames_;
    if (t > clock_.monotonic_ns() && clock_.advance_to(t) != hal::Status::kOk) ++time_backwards_;
    if (t < clock_.monotonic_ns()) ++time_backwards_;
  }
}

hal::Status script_pps_edges(hal::ScriptedGpioLine& line, std::int64_t epoch_ns, std::int64_t duration_ns) {
  constexpr std::int64_t kSecond = 1'000'000'000;
  std::int64_t phase = epoch_ns % kSecond;
  if (phase < 0) phase += kSecond;
  for (std::int64_t m = (kSecond - phase) % kSecond; m <= duration_ns; m += kSecond) {
    const hal::Status s = line.push_edge(hal::GpioEdge{hal::GpioEdge::Kind::kRising, m});
    if (s != hal::Status::kOk) return s;
  }
  return hal::Status::kOk;
}

}  // namespace v2xloc::firmware
