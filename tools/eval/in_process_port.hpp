// The in-process evaluator's side of the period driver (firmware/wire/period_driver.hpp): the
// driver decides, on the decoded wire inputs, which shares are admitted, checked and handed to the
// map, exactly as in the firmware; this port then hands the localizer the recording's
// full-precision clouds instead of the 4 mm wire-quantised ones (points and per-point times only:
// source, time stamps and poses are the decoded ones; a cloud over the firmware's capacity thinned
// as its reassembler thins it), adds the frame's stereo disparity (not on the wire) and times
// every localizer call.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "firmware/wire/localizer_port.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"
#include "tools/eval/stage_clock.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

namespace v2xloc::eval {

class InProcessPort final : public firmware::LocalizerQuestions<Localizer> {
 public:
  InProcessPort(Localizer& localizer, StageClock& stages) : LocalizerQuestions(localizer), stages_(stages) {}

  // A map share's recorded cloud, before its wire event is fed; shares stamped before
  // `drop_before_ns` (recording time) are forgotten (the verifier refuses them as too old anyway).
  void keep_share(std::uint32_t sender_id, std::int64_t stamp_ns, cloud_io::PointCloud&& cloud,
                  std::int64_t drop_before_ns);
  // The next ego scan's recorded cloud and stereo disparity (empty: none), before its event is fed.
  void set_scan(cloud_io::PointCloud&& scan, const StereoInput& stereo);

  // Wall time of the localizer calls since the last call [s].
  double take_seconds() {
    const double s = seconds_;
    seconds_ = 0.0;
    return s;
  }
  // Empty unless the driver handed over a share or scan whose recorded cloud was not given.
  const std::string& error() const { return error_; }

  void on_vehicle(const VehicleInput& input) override;
  void on_gnss(const GnssInput& input) override;
  void on_imu(const ImuInput& input) override;
  MapInsertResult on_map_cloud(const MapCloudInput& input) override;
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input) override;

 private:
  // A localizer call: its stage marked at the start, its wall time added at the end.
  void begin(LocalizerStage stage);
  void end(LocalizerStage stage);

  StageClock& stages_;
  std::map<std::pair<std::uint32_t, std::int64_t>, cloud_io::PointCloud> shares_;  // by (sender, stamp ns)
  cloud_io::PointCloud scan_;
  bool has_scan_ = false;
  StereoInput stereo_{};
  double seconds_ = 0.0;
  std::chrono::steady_clock::time_point call_start_{};
  std::string error_;
};

}  // namespace v2xloc::eval
