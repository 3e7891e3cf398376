// When a map share reaches map fusion: the firmware checks at most
// kMaxSignatureVerificationsPerPeriod signatures per 10 Hz period and keeps at most
// kShareVerifyQueueCapacity shares waiting (full: the oldest gives way). This class is that
// schedule and nothing else: a ring of slot indices; its user (ShareVerificationQueue) keeps the payload per
// slot. Allocation-free, bounded.
#pragma once

#include <cstddef>
#include <cstdint>

namespace v2xloc::firmware {

// Signature checks per period (one ego scan = one 10 Hz period of 100 M instructions on the
// A53-class target). Measured (callgrind, host, 16 000-point share, tools/bench/share_cost.cpp):
// ECDSA P-256 verify 11.9 M instructions; hashing the share's wire bytes (6.3 M) is paid fragment
// by fragment as they arrive, not here. 2 verifies = 23.7 M, a quarter of the period; with six
// sources sending at once the period's trust work is 6 x 6.3 + 2 x 11.9 = 62 M (all six verified
// at once: 109 M, over budget), the other four follow in the next two periods.
inline constexpr std::size_t kMaxSignatureVerificationsPerPeriod = 2;
// Completed, admitted shares waiting for their ECDSA verification: one slot for every source that
// may send in the same period (infrastructure units and agents share a 2 Hz cycle, so they arrive
// together: 6 on the recordings), four periods of backlog at kMaxSignatureVerificationsPerPeriod.
// A queue of 4 dropped the same two sources' shares every cycle (they arrive first), so those
// units never reached the map. Overflow drops the OLDEST waiting share (counted).
inline constexpr std::size_t kShareVerifyQueueCapacity = 8;

// Shares to verify and fuse at one period boundary: the schedule's cap, or fewer when the localizer
// asks for fewer (Localizer::map_clouds_per_period: one while tracking).
inline std::size_t shares_this_period(std::uint32_t localizer_limit) {
  return localizer_limit < kMaxSignatureVerificationsPerPeriod ? localizer_limit : kMaxSignatureVerificationsPerPeriod;
}

template <std::size_t Capacity, std::size_t PerPeriod>
class SharePeriodSchedule {
  static_assert(Capacity > 0 && PerPeriod > 0);

 public:
  static constexpr std::size_t kCapacity = Capacity;
  static constexpr std::size_t kPerPeriod = PerPeriod;

  struct Admission {
    std::size_t slot = 0;         // where the caller stores the share's payload
    bool dropped_oldest = false;  // the queue was full: the oldest waiting share was dropped
  };

  // A share arrived: the slot to fill (it is released after every share admitted before it).
  Admission admit() {
    Admission a;
    if (count_ == Capacity) {
      head_ = (head_ + 1) % Capacity;
      --count_;
      a.dropped_oldest = true;
    }
    a.slot = (head_ + count_) % Capacity;
    ++count_;
    return a;
  }
  // A period boundary (an ego scan): the per-period budget starts again.
  void begin_period() { released_ = 0; }
  // The oldest waiting share, if this period's budget allows one more; false otherwise.
  bool release(std::size_t& slot) {
    if (count_ == 0 || released_ >= PerPeriod) return false;
    slot = head_;
    head_ = (head_ + 1) % Capacity;
    --count_;
    ++released_;
    return true;
  }
  // The released share needed no budget after all (refused by a cheap check before its
  // signature was verified): the period may release one more.
  void refund() {
    if (released_ > 0) --released_;
  }
  std::size_t waiting() const { return count_; }
  // i-th waiting share (0 = oldest), i < waiting().
  std::size_t waiting_slot(std::size_t i) const { return (head_ + i) % Capacity; }

 private:
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  std::size_t released_ = 0;
};

using ShareSchedule = SharePeriodSchedule<kShareVerifyQueueCapacity, kMaxSignatureVerificationsPerPeriod>;

}  // namespace v2xloc::firmware
