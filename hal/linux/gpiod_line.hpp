// libgpiod (v1.6 C API, Debian 12) backend: one line as an edge-event input (GNSS PPS) or as an
// output (the "localized" LED). Edge time stamps come from the kernel (GPIO v1 uAPI: CLOCK_MONOTONIC
// on Linux >= 5.7, CLOCK_REALTIME before).
#pragma once

#include "hal/gpio_line.hpp"
#include "hal/linux/error_text.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace v2xloc::hal {

struct GpiodLineOptions {
  enum class Mode : unsigned char { kEdgeInput, kOutput };
  const char* chip = "gpiochip0";  // name ("gpiochip0") or path ("/dev/gpiochip0")
  unsigned offset = 0;
  Mode mode = Mode::kEdgeInput;
  bool initial_value = false;      // outputs
  bool active_low = false;
  const char* consumer = "v2xloc";
};

class GpiodLine final : public GpioLine {
 public:
  GpiodLine() = default;
  ~GpiodLine() override;
  GpiodLine(const GpiodLine&) = delete;
  GpiodLine& operator=(const GpiodLine&) = delete;

  Status open(const GpiodLineOptions& options);
  void close();
  int event_fd() const;  // for poll() on input lines, -1 otherwise
  const char* last_error() const { return error_.c_str(); }

  Status read_edge(GpioEdge& edge) override;
  Status set_value(bool active) override;
  Status get_value(bool& active) override;

 private:
  gpiod_chip* chip_ = nullptr;
  gpiod_line* line_ = nullptr;
  GpiodLineOptions::Mode mode_ = GpiodLineOptions::Mode::kEdgeInput;
  linux_backend::ErrorText error_;
};

}  // namespace v2xloc::hal
