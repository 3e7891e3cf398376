// The period's CAN inputs (vehicle signals, closed GNSS fixes) in arrival order, held until the
// period closes so that the IMU samples read in the same period can be merged in by time: the
// filter then sees gyro and wheel measurements in sequence instead of rolling back for each gyro
// mean. Fixed capacity; when full the period driver releases what it holds early (counted).
#pragma once

#include <cstddef>

#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

struct PendingInput {
  enum class Kind { kVehicle, kGnss } kind = Kind::kVehicle;
  VehicleInput vehicle{};
  GnssInput gnss{};
  double t() const { return kind == Kind::kVehicle ? vehicle.t : gnss.t; }
};

class PendingInputs {
 public:
  static constexpr std::size_t kCapacity = 512;  // 5 s of 100 Hz vehicle signals with GNSS

  bool full() const { return count_ == kCapacity; }
  bool empty() const { return count_ == 0; }
  std::size_t size() const { return count_; }
  // False when full (the caller releases first).
  bool push(const PendingInput& input) {
    if (full()) return false;
    items_[(head_ + count_) % kCapacity] = input;
    ++count_;
    return true;
  }
  const PendingInput& front() const { return items_[head_]; }
  void pop() {
    head_ = (head_ + 1) % kCapacity;
    --count_;
  }

 private:
  PendingInput items_[kCapacity];
  std::size_t head_ = 0;
  std::size_t count_ = 0;
};

}  // namespace v2xloc::firmware
