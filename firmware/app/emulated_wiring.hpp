// Emulation-only wiring for v2xloc-firmware --emulated (never part of the application library):
// a CanBus decorator that lets the replayer drive the SimClock over the emulated CAN link, and the
// PPS edges of a simulated GNSS receiver.
#pragma once

#include <cstdint>

#include "hal/can_bus.hpp"
#include "hal/emulated/scripted_gpio_line.hpp"
#include "hal/emulated/sim_clock.hpp"

namespace v2xloc::firmware {

// Consumes sim-time frames (wire_conventions.hpp: kSimTimeCanId) by advancing the SimClock, and
// passes every other frame through. Frames after a sim-time frame are stamped at that time by the
// inner EmulatedCanBus, so receive stamps equal the recording's stamps: deterministic replay.
class SimTimeCanBus final : public hal::CanBus {
 public:
  SimTimeCanBus(hal::CanBus& inner, hal::SimClock& clock) : inner_(inner), clock_(clock) {}
  hal::Status send(const hal::CanFrame& frame) override { return inner_.send(frame); }
  hal::Status receive(hal::CanRxFrame& out) override;
  hal::Status set_filters(std::span<const hal::CanFilter> filters) override { return inner_.set_filters(filters); }
  hal::Status accept_all() override { return inner_.accept_all(); }
  hal::Status set_error_mask(std::uint32_t error_classes) override { return inner_.set_error_mask(error_classes); }
  hal::CanCounters counters() const override { return inner_.counters(); }
  std::uint64_t time_frames() const { return time_frames_; }
  std::uint64_t time_backwards() const { return time_backwards_; }

 private:
  hal::CanBus& inner_;
  hal::SimClock& clock_;
  std::uint64_t time_frames_ = 0;
  std::uint64_t time_backwards_ = 0;
};

// Rising PPS edges at every whole second of disciplined time (monotonic + epoch) in
// [0, duration_ns] of monotonic time: what a GNSS receiver's PPS output gives the ECU.
hal::Status script_pps_edges(hal::ScriptedGpioLine& line, std::int64_t epoch_ns, std::int64_t duration_ns);

}  // namespace v2xloc::firmware

namespace v2xloc::firmware {

// LED output for emulation: remembers the level and counts changes (no allocation, unlike a
// history vector); main prints it at exit.
class CountingLedLine final : public hal::GpioLine {
 public:
  hal::Status read_edge(hal::GpioEdge&) override { return hal::Status::kUnsupported; }
  hal::Status set_value(bool active) override {
    if (active != level_) ++changes_;
    level_ = active;
    return hal::Status::kOk;
  }
  hal::Status get_value(bool& active) override {
    active = level_;
    return hal::Status::kOk;
  }
  std::uint64_t changes() const { return changes_; }

 private:
  bool level_ = false;
  std::uint64_t changes_ = 0;
};

}  // namespace v2xloc::firmware
