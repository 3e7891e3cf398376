// The localizer's stage probe on the host (v2xloc-eval --timing, callgrind dumps).
#pragma once

#include <chrono>
#include <cstdio>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define V2XLOC_HAVE_CALLGRIND 1
#endif

#include "tools/eval/offline_run.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"

namespace v2xloc::eval {

// Wall time between marks per stage, and (under callgrind, when asked) one stats dump per
// finished stage so instructions split the same way.
class StageClock {
 public:
  using Clock = std::chrono::steady_clock;
  StageClock(bool timing, bool dumps) : timing_(timing), dumps_(dumps) {}
  static void on_mark(void* self, LocalizerStage s) { static_cast<StageClock*>(self)->mark(s); }
  StageProbe probe() { return StageProbe{&StageClock::on_mark, this}; }
  bool active() const { return timing_ || dumps_; }
  void mark(LocalizerStage s) {
    if (!active()) return;
    const auto now = Clock::now();
    if (current_ != LocalizerStage::kIdle) {
      ms_[static_cast<std::size_t>(current_)] += std::chrono::duration<double, std::milli>(now - last_).count();
    }
#ifdef V2XLOC_HAVE_CALLGRIND
    if (dumps_ && RUNNING_ON_VALGRIND) {
      char label[64];
      std::snprintf(label, sizeof label, "frame %d %s", frame_, stage_name(current_));
      CALLGRIND_DUMP_STATS_AT(label);
    }
#endif
    current_ = s;
    last_ = Clock::now();
  }
  void begin_period(int frame) {
    mark(LocalizerStage::kIdle);
    frame_ = frame;
    ms_.fill(0.0);
  }
  const StageMs& period_ms() const { return ms_; }

 private:
  bool timing_, dumps_;
  int frame_ = -1;
  LocalizerStage current_ = LocalizerStage::kIdle;
  Clock::time_point last_ = Clock::now();
  StageMs ms_{};
};

}  // namespace v2xloc::eval
