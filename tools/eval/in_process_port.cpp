#include "tools/eval/in_process_port.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "firmware/wire/cloud_input_decoder.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"

namespace v2xloc::eval {

namespace {

// The entries of one per-point attribute that the thinning keeps, in order (an attribute the
// cloud does not carry, of another size, is left alone).
template <class T>
void keep_evenly(std::vector<T>& v, std::size_t n, std::size_t kept) {
  if (v.size() != n) return;
  std::size_t out = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (kept_evenly(j, n, kept)) v[out++] = v[j];
  }
  v.resize(out);
}

// A recorded cloud over the firmware's cloud capacity, thinned as its reassembler thins the wire
// cloud (firmware/protocol/pointcloud_udp.cpp: the same points, kept evenly by index), so both
// paths give the localizer the same points but for the wire's quantisation.
void thin_like_reassembler(cloud_io::PointCloud& cloud) {
  const std::size_t n = cloud.points.size();
  const std::size_t kept = std::min(n, firmware::kMaxCloudPoints);
  if (kept == n) return;
  keep_evenly(cloud.time, n, kept);
  keep_evenly(cloud.intensity, n, kept);
  keep_evenly(cloud.normals, n, kept);
  keep_evenly(cloud.points, n, kept);
  cloud.width = 0;  // no longer organized
  cloud.height = 1;
}

}  // namespace

void InProcessPort::begin(LocalizerStage stage) {
  stages_.mark(stage);
  call_start_ = std::chrono::steady_clock::now();
}

void InProcessPort::end(LocalizerStage stage) {
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - call_start_).count();
  stages_.mark(stage);
}

void InProcessPort::keep_share(std::uint32_t sender_id, std::int64_t stamp_ns, cloud_io::PointCloud&& cloud,
                               std::int64_t drop_before_ns) {
  for (auto it = shares_.begin(); it != shares_.end();) {
    it = it->first.second < drop_before_ns ? shares_.erase(it) : std::next(it);
  }
  thin_like_reassembler(cloud);
  shares_[{sender_id, stamp_ns}] = std::move(cloud);
}

void InProcessPort::set_scan(cloud_io::PointCloud&& scan, const StereoInput& stereo) {
  scan_ = std::move(scan);
  thin_like_reassembler(scan_);
  has_scan_ = true;
  stereo_ = stereo;
}

void InProcessPort::on_vehicle(const VehicleInput& input) {
  begin(LocalizerStage::kInputs);
  localizer_.on_vehicle(input);
  end(LocalizerStage::kIdle);
}

void InProcessPort::on_gnss(const GnssInput& input) {
  begin(LocalizerStage::kInputs);
  localizer_.on_gnss(input);
  end(LocalizerStage::kIdle);
}

void InProcessPort::on_imu(const ImuInput& input) {
  begin(LocalizerStage::kInputs);
  localizer_.on_imu(input);
  end(LocalizerStage::kIdle);
}

MapInsertResult InProcessPort::on_map_cloud(const MapCloudInput& input) {
  // The decoded time is stamp_ns * 1e-9 (localizer_time_s): rounding it back gives the stamp.
  const auto it = shares_.find({input.source_id, std::llround(input.t * 1e9)});
  if (it == shares_.end()) {
    error_ = "in-process run: no recorded cloud for the share of sender " + std::to_string(input.source_id) +
             " at t " + std::to_string(input.t);
    return MapInsertResult{};
  }
  MapCloudInput full = input;
  full.points = std::span<const Vec3f>(it->second.points.data(), it->second.points.size());
  begin(LocalizerStage::kMapInsert);
  const MapInsertResult r = localizer_.on_map_cloud(full);
  end(LocalizerStage::kIdle);
  shares_.erase(it);  // a share reaches the map once
  return r;
}

const LocalizerFrameOutput& InProcessPort::on_ego_scan(const EgoScanInput& input) {
  EgoScanInput full = input;
  if (has_scan_) {
    full.points = std::span<const Vec3f>(scan_.points.data(), scan_.points.size());
    full.point_times = scan_.time.size() == scan_.points.size()
                           ? std::span<const float>(scan_.time.data(), scan_.time.size())
                           : std::span<const float>{};
    full.stereo = stereo_;
  } else if (!input.points.empty()) {  // the period timer's scan has no points at any precision
    error_ = "in-process run: no recorded cloud for the ego scan at t " + std::to_string(input.t);
  }
  has_scan_ = false;
  begin(LocalizerStage::kIdle);  // the localizer marks its own stages during the scan
  const LocalizerFrameOutput& out = localizer_.on_ego_scan(full);
  end(LocalizerStage::kIdle);
  return out;
}

}  // namespace v2xloc::eval
