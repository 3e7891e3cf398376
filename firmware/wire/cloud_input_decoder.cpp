#include "firmware/wire/cloud_input_decoder.hpp"

#include <cmath>

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware {
namespace {

// Byte 5 of the cloud header is the message type (the CRC is checked by the reassembler).
bool is_ego_scan_datagram(std::span<const std::uint8_t> datagram) {
  return datagram.size() > 5 && datagram[5] == static_cast<std::uint8_t>(protocol::CloudMessageType::kEgoScan);
}

}  // namespace

bool sensor_pose_matrix(const protocol::SensorPose& pose, Mat4d& out) {
  const double* q = pose.quaternion_xyzw;
  const double norm_sq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(std::abs(norm_sq - 1.0) < 1e-3)) return false;  // also rejects NaN
  for (const double p : pose.position_m) {
    if (!std::isfinite(p)) return false;
  }
  Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
  quat.normalize();
  out = Mat4d::Identity();
  out.topLeftCorner<3, 3>() = quat.toRotationMatrix();
  out(0, 3) = pose.position_m[0];
  out(1, 3) = pose.position_m[1];
  out(2, 3) = pose.position_m[2];
  return true;
}

void copy_cloud_points(const protocol::ReassembledCloud& cloud, std::span<Vec3f> out) {
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = Vec3f(cloud.xyz[3u * i], cloud.xyz[3u * i + 1], cloud.xyz[3u * i + 2]);
  }
}

DatagramChannel CloudInputDecoder::channel_of(std::span<const std::uint8_t> datagram) {
  const bool ego = !protocol::is_signature_datagram(datagram) && is_ego_scan_datagram(datagram);
  return ego ? DatagramChannel::kEgo : DatagramChannel::kV2x;
}

DatagramResult CloudInputDecoder::on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns,
                                              std::int64_t local_time_ns, DatagramChannel channel) {
  ++counters_.datagrams;
  completed_pending_ = false;
  DatagramResult out;
  // An ego scan only on the ego endpoint; a map share or a signature only on the V2X one.
  const bool signature = protocol::is_signature_datagram(datagram);
  const bool ego_only = !signature && datagram.size() > 5 && is_ego_scan_datagram(datagram);
  const bool typed = signature || datagram.size() > 5;
  if (typed && ego_only != (channel == DatagramChannel::kEgo)) {
    ++counters_.wrong_channel;
    return out;
  }
  if (signature) {
    out.signature = true;
    return out;
  }
  completed_local_time_ns_ = local_time_ns;
  const protocol::CloudStatus s = reassembler_.push(datagram, now_ns);
  const protocol::AcceptedFragment& accepted = reassembler_.last_accepted();
  if (accepted.valid && accepted.type == protocol::CloudMessageType::kMapShare) {
    out.share_fragment = &accepted;
    out.share_t = localizer_time_s(static_cast<std::int64_t>(accepted.timestamp_ns), epoch_ns_);
  }
  switch (s) {
    case protocol::CloudStatus::kFrameComplete:
      completed_pending_ = true;
      out.completed = true;
      break;
    case protocol::CloudStatus::kOk:
    case protocol::CloudStatus::kDuplicate:   // normal on UDP: counted by the reassembler
    case protocol::CloudStatus::kStaleFrame:
      break;
    default:
      ++counters_.datagrams_rejected;
      break;
  }
  return out;
}

DecodedCloud CloudInputDecoder::decode_completed(std::int64_t local_time_ns) {
  completed_local_time_ns_ = local_time_ns;
  return decode_completed();
}

DecodedCloud CloudInputDecoder::decode_completed() {
  DecodedCloud out;
  if (!completed_pending_) return out;
  completed_pending_ = false;
  const protocol::ReassembledCloud& cloud = reassembler_.completed();
  const protocol::CloudFrameInfo& info = cloud.info;
  Mat4d pose;
  const std::uint32_t n = cloud.point_count;
  const bool ego = info.type == protocol::CloudMessageType::kEgoScan && info.sender_id == kEgoSenderId;
  if (!sensor_pose_matrix(info.pose, pose) || n > points_.size() || cloud.xyz.size() < 3u * n ||
      (info.type != protocol::CloudMessageType::kMapShare && !ego)) {
    ++counters_.clouds_rejected;
    out.kind = CloudKind::kRejected;
    return out;
  }
  const double t = localizer_time_s(static_cast<std::int64_t>(info.timestamp_ns), epoch_ns_);
  if (!ego) {
    out.kind = CloudKind::kMapShare;
    out.map.t = t;
    out.map.world_T_sensor = pose;
    return out;
  }
  return decode_ego_scan(cloud, pose, t);
}

bool CloudInputDecoder::ego_time_plausible(std::uint64_t stamp_ns) const {
  const std::int64_t stamp = static_cast<std::int64_t>(stamp_ns & 0x7FFFFFFFFFFFFFFFull);
  return stamp_ns <= 0x7FFFFFFFFFFFFFFFull && stamp <= completed_local_time_ns_ + kEgoScanMaxClockSkewNs &&
         stamp >= completed_local_time_ns_ - kEgoScanMaxClockSkewNs && !(have_ego_time_ && stamp_ns <= last_ego_stamp_ns_);
}

DecodedCloud CloudInputDecoder::decode_ego_scan(const protocol::ReassembledCloud& cloud, const Mat4d& body_T_lidar,
                                                double t) {
  DecodedCloud out;
  const std::uint32_t n = cloud.point_count;
  copy_cloud_points(cloud, std::span<Vec3f>(points_.data(), n));
  // A refused scan is counted and leaves no trace, so it cannot freeze the scans after it.
  out.frame_index = ego_frames_++;
  if (!ego_time_plausible(cloud.info.timestamp_ns)) {
    ++counters_.ego_time_rejected;
    out.kind = CloudKind::kEgoRejected;
    return out;
  }
  have_ego_time_ = true;
  last_ego_stamp_ns_ = cloud.info.timestamp_ns;
  EgoScanInput& in = out.ego;
  in.t = t;
  in.points = std::span<const Vec3f>(points_.data(), n);
  if (cloud.time_offset_ticks.size() == n) {
    for (std::uint32_t i = 0; i < n; ++i) {
      point_times_[i] = static_cast<float>(cloud.time_offset_ticks[i] * protocol::kPointTimeTick);
    }
    in.point_times = std::span<const float>(point_times_.data(), n);
  }
  in.body_T_lidar = body_T_lidar;
  ++counters_.ego_scans;
  out.kind = CloudKind::kEgoScan;
  return out;
}

}  // namespace v2xloc::firmware
