#include "hal/linux/gpiod_line.hpp"

#include <gpiod.h>

#include <cerrno>
#include <cstdio>

#include "hal/linux/linux_clock.hpp"

namespace v2xloc::hal {

GpiodLine::~GpiodLine() { close(); }

void GpiodLine::close() {
  if (line_ != nullptr) gpiod_line_release(line_);
  if (chip_ != nullptr) gpiod_chip_close(chip_);
  line_ = nullptr;
  chip_ = nullptr;
}

Status GpiodLine::open(const GpiodLineOptions& o) {
  close();
  error_.clear();
  if (o.chip == nullptr) return Status::kInvalidArgument;
  char what[96];
  errno = 0;
  chip_ = o.chip[0] == '/' ? gpiod_chip_open(o.chip) : gpiod_chip_open_by_name(o.chip);
  if (chip_ == nullptr) {
    std::snprintf(what, sizeof what, "gpiod_chip_open(%s)", o.chip);
    return error_.set_errno(what, errno != 0 ? errno : ENODEV);
  }
  line_ = gpiod_chip_get_line(chip_, o.offset);
  if (line_ == nullptr) {
    const int err = errno != 0 ? errno : EINVAL;
    std::snprintf(what, sizeof what, "gpiod_chip_get_line(%s, %u)", o.chip, o.offset);
    close();
    return error_.set_errno(what, err);
  }
  const int flags = o.active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  const int rc = o.mode == GpiodLineOptions::Mode::kOutput
                     ? gpiod_line_request_output_flags(line_, o.consumer, flags, o.initial_value ? 1 : 0)
                     : gpiod_line_request_both_edges_events_flags(line_, o.consumer, flags);
  if (rc != 0) {
    const int err = errno != 0 ? errno : EBUSY;
    std::snprintf(what, sizeof what, "gpiod_line_request(%s:%u)", o.chip, o.offset);
    line_ = nullptr;  // not requested: nothing to release
    close();
    return error_.set_errno(what, err);
  }
  mode_ = o.mode;
  return Status::kOk;
}

int GpiodLine::event_fd() const {
  return (line_ != nullptr && mode_ == GpiodLineOptions::Mode::kEdgeInput) ? gpiod_line_event_get_fd(line_) : -1;
}

Status GpiodLine::read_edge(GpioEdge& edge) {
  if (line_ == nullptr) return Status::kNotOpen;
  if (mode_ != GpiodLineOptions::Mode::kEdgeInput) return Status::kUnsupported;
  const timespec no_wait{0, 0};
  const int ready = gpiod_line_event_wait(line_, &no_wait);
  if (ready == 0) return Status::kWouldBlock;
  if (ready < 0) return error_.set_errno("gpiod_line_event_wait", errno);
  gpiod_line_event ev{};
  if (gpiod_line_event_read(line_, &ev) != 0) return error_.set_errno("gpiod_line_event_read", errno);
  edge.kind = ev.event_type == GPIOD_LINE_EVENT_RISING_EDGE ? GpioEdge::Kind::kRising : GpioEdge::Kind::kFalling;
  edge.timestamp_ns = to_ns(ev.ts);
  return Status::kOk;
}

Status GpiodLine::set_value(bool active) {
  if (line_ == nullptr) return Status::kNotOpen;
  if (mode_ != GpiodLineOptions::Mode::kOutput) return Status::kUnsupported;
  if (gpiod_line_set_value(line_, active ? 1 : 0) != 0) return error_.set_errno("gpiod_line_set_value", errno);
  return Status::kOk;
}

Status GpiodLine::get_value(bool& active) {
  if (line_ == nullptr) return Status::kNotOpen;
  const int v = gpiod_line_get_value(line_);
  if (v < 0) return error_.set_errno("gpiod_line_get_value", errno);
  active = v != 0;
  return Status::kOk;
}

}  // namespace v2xloc::hal
