// The period driver's view of the localizer (period_driver.hpp): the five input calls and the
// per-frame output, behind a small virtual interface so the driver does not depend on which
// localizer type its user links in. LocalizerAdapter binds any type with the v2xloc::Localizer API
// (on_vehicle / on_gnss / on_imu / on_map_cloud / on_ego_scan and the share questions) without copying: the
// localizer object itself stays a static owned by main. The in-process evaluator has its own port
// (tools/eval/in_process_port.hpp).
#pragma once

#include "firmware/wire/input_decoder.hpp"
#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/localizer.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"

namespace v2xloc::firmware {

// Also the decoder's MapShareWanted: shares the map would not fuse skip their signature check.
class LocalizerPort : public MapShareWanted {
 public:
  bool wants(std::uint32_t /*source_id*/, double /*t*/) const override { return true; }
  // Map shares to verify and fuse in the coming period (the schedule's cap applies as well).
  virtual std::uint32_t map_clouds_per_period() const { return ~std::uint32_t{0}; }
  // This period's work outside the localizer (trust), for its period budget.
  virtual void add_period_work(double /*instructions*/) {}
  virtual void on_vehicle(const VehicleInput& input) = 0;
  virtual void on_gnss(const GnssInput& input) = 0;
  virtual void on_imu(const ImuInput& input) = 0;
  virtual MapInsertResult on_map_cloud(const MapCloudInput& input) = 0;
  virtual const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input) = 0;

 protected:
  ~LocalizerPort() = default;  // never deleted through the interface (static objects)
};

// The share questions and the budget answered by a localizer with the v2xloc::Localizer API; the
// five input calls are left to the port (the adapter below forwards them, the in-process
// evaluator's swaps in the recorded clouds).
template <class LocalizerT>
class LocalizerQuestions : public LocalizerPort {
 public:
  explicit LocalizerQuestions(LocalizerT& localizer) : localizer_(localizer) {}
  bool wants(std::uint32_t source_id, double t) const override { return localizer_.wants_map_cloud(source_id, t); }
  bool fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor,
                       std::span<const Vec3f> points) const override {
    return localizer_.map_cloud_fits_background(source_id, world_T_sensor, points);
  }
  bool awaiting_first_map() const override { return !localizer_.has_map(); }
  std::uint32_t map_clouds_per_period() const override { return localizer_.map_clouds_per_period(); }
  void add_period_work(double instructions) override { localizer_.add_period_work(instructions); }
  LocalizerT& localizer() { return localizer_; }

 protected:
  ~LocalizerQuestions() = default;
  LocalizerT& localizer_;
};

template <class LocalizerT>
class LocalizerAdapter final : public LocalizerQuestions<LocalizerT> {
 public:
  explicit LocalizerAdapter(LocalizerT& localizer) : LocalizerQuestions<LocalizerT>(localizer) {}
  void on_vehicle(const VehicleInput& input) override { this->localizer_.on_vehicle(input); }
  void on_gnss(const GnssInput& input) override { this->localizer_.on_gnss(input); }
  void on_imu(const ImuInput& input) override { this->localizer_.on_imu(input); }
  MapInsertResult on_map_cloud(const MapCloudInput& input) override { return this->localizer_.on_map_cloud(input); }
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input) override {
    return this->localizer_.on_ego_scan(input);
  }
};

}  // namespace v2xloc::firmware
