// GPIO line driven by a script of timestamped edges (e.g. the PPS edges of a recording): an edge
// becomes readable once the clock reaches its time stamp. Output writes are recorded with the
// clock's time, so tests and the replayer can check the LED.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "hal/clock.hpp"
#include "hal/gpio_line.hpp"

namespace v2xloc::hal {

class ScriptedGpioLine final : public GpioLine {
 public:
  struct OutputChange {
    std::int64_t timestamp_ns = 0;
    bool active = false;
  };

  explicit ScriptedGpioLine(const Clock& clock, bool is_output = false) : clock_(clock), output_(is_output) {}

  // Edges must be queued in non-decreasing time order (else kInvalidArgument).
  Status push_edge(const GpioEdge& edge);
  // Text script, one edge per line: "<monotonic_ns> rising|falling"; '#' starts a comment.
  Status load_script(const char* path);
  std::size_t pending_edges() const { return edges_.size(); }
  const std::vector<OutputChange>& output_history() const { return history_; }

  Status read_edge(GpioEdge& edge) override;
  Status set_value(bool active) override;
  Status get_value(bool& active) override;

 private:
  const Clock& clock_;
  bool output_;
  bool level_ = false;
  std::deque<GpioEdge> edges_;
  std::vector<OutputChange> history_;
};

}  // namespace v2xloc::hal
