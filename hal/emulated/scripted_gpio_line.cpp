#include "hal/emulated/scripted_gpio_line.hpp"

#include <cstdio>
#include <cstring>

namespace v2xloc::hal {

Status ScriptedGpioLine::push_edge(const GpioEdge& edge) {
  if (output_) return Status::kUnsupported;
  if (!edges_.empty() && edge.timestamp_ns < edges_.back().timestamp_ns) return Status::kInvalidArgument;
  edges_.push_back(edge);
  return Status::kOk;
}

Status ScriptedGpioLine::load_script(const char* path) {
  std::FILE* f = std::fopen(path, "r");
  if (f == nullptr) return Status::kIoError;
  char line[256];
  Status result = Status::kOk;
  while (result == Status::kOk && std::fgets(line, sizeof line, f) != nullptr) {
    if (char* hash = std::strchr(line, '#')) *hash = '\0';
    long long t = 0;
    char kind[16] = {};
    const int fields = std::sscanf(line, "%lld %15s", &t, kind);
    if (fields <= 0) continue;  // blank or comment
    if (fields != 2) {
      result = Status::kMalformed;
    } else if (std::strcmp(kind, "rising") == 0) {
      result = push_edge(GpioEdge{GpioEdge::Kind::kRising, t});
    } else if (std::strcmp(kind, "falling") == 0) {
      result = push_edge(GpioEdge{GpioEdge::Kind::kFalling, t});
    } else {
      result = Status::kMalformed;
    }
  }
  std::fclose(f);
  return result;
}

Status ScriptedGpioLine::read_edge(GpioEdge& edge) {
  if (output_) return Status::kUnsupported;
  if (edges_.empty() || edges_.front().timestamp_ns > clock_.monotonic_ns()) return Status::kWouldBlock;
  edge = edges_.front();
  edges_.pop_front();
  level_ = edge.kind == GpioEdge::Kind::kRising;
  return Status::kOk;
}

Status ScriptedGpioLine::set_value(bool active) {
  if (!output_) return Status::kUnsupported;
  if (history_.empty() || history_.back().active != active) history_.push_back({clock_.monotonic_ns(), active});
  level_ = active;
  return Status::kOk;
}

Status ScriptedGpioLine::get_value(bool& active) {
  active = level_;
  return Status::kOk;
}

}  // namespace v2xloc::hal
