#include "firmware/protocol/pointcloud_udp.hpp"

#include <bit>
#include <cmath>
#include <cstring>

#include "firmware/protocol/crc32.hpp"
#include "firmware/protocol/round_half_away.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"
#include "hal/little_endian.hpp"

namespace v2xloc::protocol {
namespace {

using namespace pointcloud_wire;

using namespace hal::le;  // the house's one little-endian byte packer

// Header field offsets (see WIRE_FORMATS.md).
enum Offset : std::size_t {
  kOffMagic = 0, kOffVersion = 4, kOffType = 5, kOffFlags = 6, kOffHeaderBytes = 8,
  kOffSensorId = 10, kOffSenderId = 12, kOffFrameSeq = 16, kOffFragIndex = 20, kOffFragCount = 22,
  kOffTimestamp = 24, kOffPosition = 32, kOffQuaternion = 56, kOffScale = 88, kOffPointsInFrag = 92,
  kOffPointsPerFrag = 94, kOffTotalPoints = 96, kOffPayloadBytes = 100, kOffReserved = 102,
};
static_assert(kOffReserved + 2 == kHeaderBytes);

std::uint16_t flags_for(const CloudFrameInfo& info, const CloudPointsView& points) {
  std::uint16_t flags = 0;
  if (!points.intensity.empty()) flags |= cloud_flags::kIntensity;
  if (!points.time_offset_ticks.empty()) flags |= cloud_flags::kPointTime;
  if (info.width == CoordWidth::kInt32) flags |= cloud_flags::kCoordsInt32;
  return flags;
}

void write_header(std::uint8_t* p, const CloudFragmentHeader& h) {
  put_u32(p + kOffMagic, kMagic);
  put_u8(p + kOffVersion, kVersion);
  put_u8(p + kOffType, static_cast<std::uint8_t>(h.info.type));
  put_u16(p + kOffFlags, h.flags);
  put_u16(p + kOffHeaderBytes, static_cast<std::uint16_t>(kHeaderBytes));
  put_u16(p + kOffSensorId, h.info.sensor_id);
  put_u32(p + kOffSenderId, h.info.sender_id);
  put_u32(p + kOffFrameSeq, h.info.frame_seq);
  put_u16(p + kOffFragIndex, h.fragment_index);
  put_u16(p + kOffFragCount, h.fragment_count);
  put_u64(p + kOffTimestamp, h.info.timestamp_ns);
  for (int i = 0; i < 3; ++i) put_f64(p + kOffPosition + 8 * i, h.info.pose.position_m[i]);
  for (int i = 0; i < 4; ++i) put_f64(p + kOffQuaternion + 8 * i, h.info.pose.quaternion_xyzw[i]);
  put_f32(p + kOffScale, h.info.scale_m);
  put_u16(p + kOffPointsInFrag, h.points_in_fragment);
  put_u16(p + kOffPointsPerFrag, h.points_per_fragment);
  put_u32(p + kOffTotalPoints, h.total_points);
  put_u16(p + kOffPayloadBytes, h.payload_bytes);
  put_u16(p + kOffReserved, 0);
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

bool same_frame(const CloudFragmentHeader& a, const CloudFragmentHeader& b) {
  if (a.info.type != b.info.type || a.flags != b.flags || a.fragment_count != b.fragment_count ||
      a.points_per_fragment != b.points_per_fragment || a.total_points != b.total_points ||
      a.info.timestamp_ns != b.info.timestamp_ns ||
      std::bit_cast<std::uint32_t>(a.info.scale_m) != std::bit_cast<std::uint32_t>(b.info.scale_m)) {
    return false;
  }
  for (int i = 0; i < 3; ++i) {
    if (!same_bits(a.info.pose.position_m[i], b.info.pose.position_m[i])) return false;
  }
  for (int i = 0; i < 4; ++i) {
    if (!same_bits(a.info.pose.quaternion_xyzw[i], b.info.pose.quaternion_xyzw[i])) return false;
  }
  return true;
}

std::uint32_t expected_points(std::uint32_t total, std::uint16_t per_fragment, std::uint16_t index) {
  const std::uint64_t first = static_cast<std::uint64_t>(index) * per_fragment;
  if (first >= total) return 0;
  const std::uint64_t rest = total - first;
  return static_cast<std::uint32_t>(rest < per_fragment ? rest : per_fragment);
}

}  // namespace

const char* to_string(CloudStatus status) {
  switch (status) {
    case CloudStatus::kOk: return "ok";
    case CloudStatus::kDone: return "done";
    case CloudStatus::kFrameComplete: return "frame complete";
    case CloudStatus::kDuplicate: return "duplicate fragment";
    case CloudStatus::kStaleFrame: return "fragment of a finished frame";
    case CloudStatus::kBufferTooSmall: return "buffer too small";
    case CloudStatus::kInvalidArgument: return "invalid argument";
    case CloudStatus::kTruncated: return "truncated datagram";
    case CloudStatus::kBadMagic: return "bad magic";
    case CloudStatus::kUnsupported: return "unsupported version/type/flags";
    case CloudStatus::kBadCrc: return "CRC mismatch";
    case CloudStatus::kMalformed: return "malformed header";
    case CloudStatus::kInconsistent: return "fragment inconsistent with its frame";
    case CloudStatus::kCapacityExceeded: return "frame exceeds reassembly capacity";
  }
  return "unknown";
}

std::size_t cloud_point_stride(std::uint16_t flags) {
  std::size_t stride = (flags & cloud_flags::kCoordsInt32) ? 12 : 6;
  if (flags & cloud_flags::kIntensity) stride += 1;
  if (flags & cloud_flags::kPointTime) stride += 2;
  return stride;
}

bool quantize_coordinate(float value_m, float scale_m, CoordWidth width, std::int32_t& out) {
  if (!std::isfinite(value_m)) return false;
  const double limit = width == CoordWidth::kInt16 ? kInt16Limit : kInt32Limit;
  const double steps = round_half_away(static_cast<double>(value_m) / static_cast<double>(scale_m));
  if (!(steps <= limit && steps >= -limit)) return false;
  out = static_cast<std::int32_t>(steps);
  return true;
}

// value -> round(value / scale) never decreases as value grows (IEEE division and rounding are
// monotonic) and is odd, so the accepted values form one interval [-m, m]. Bisect m over the bit
// patterns of the non-negative floats, which are ordered as their values: 0 is always accepted,
// infinity never.
float largest_quantizable(float scale_m, CoordWidth width) {
  std::uint32_t accepted = 0, refused = 0x7F800000u;
  std::int32_t q = 0;
  while (refused - accepted > 1) {
    const std::uint32_t mid = accepted + (refused - accepted) / 2;
    if (quantize_coordinate(std::bit_cast<float>(mid), scale_m, width, q)) {
      accepted = mid;
    } else {
      refused = mid;
    }
  }
  return std::bit_cast<float>(accepted);
}

// ---------------------------------------------------------------------------------------------
// Fragmenter

CloudStatus PointCloudFragmenter::begin(const CloudFrameInfo& info, const CloudPointsView& points,
                                        std::size_t max_datagram_bytes) {
  *this = PointCloudFragmenter{};
  if (!std::isfinite(info.scale_m) || !(info.scale_m > 0.0f)) return CloudStatus::kInvalidArgument;
  if (info.type != CloudMessageType::kEgoScan && info.type != CloudMessageType::kMapShare) {
    return CloudStatus::kInvalidArgument;
  }
  if (info.width != CoordWidth::kInt16 && info.width != CoordWidth::kInt32) {
    return CloudStatus::kInvalidArgument;
  }
  if (points.xyz.size() % 3 != 0) return CloudStatus::kInvalidArgument;
  const std::size_t n = points.xyz.size() / 3;
  if ((!points.intensity.empty() && points.intensity.size() != n) ||
      (!points.time_offset_ticks.empty() && points.time_offset_ticks.size() != n) || n > 0xFFFFFFFFu) {
    return CloudStatus::kInvalidArgument;
  }
  info_ = info;
  points_ = points;
  flags_ = flags_for(info, points);
  stride_ = cloud_point_stride(flags_);
  if (max_datagram_bytes > kMaxDatagramBytes) max_datagram_bytes = kMaxDatagramBytes;
  if (max_datagram_bytes < kHeaderBytes + kTrailerBytes + stride_) return CloudStatus::kBufferTooSmall;

  // Counting needs only the range check (one compare per coordinate); next() quantizes each
  // sent point once.
  max_abs_ = largest_quantizable(info.scale_m, info.width);
  const float max_abs = max_abs_;
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = &points.xyz[3 * i];
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) {
      ++dropped_non_finite_;
    } else if (std::fabs(p[0]) > max_abs || std::fabs(p[1]) > max_abs || std::fabs(p[2]) > max_abs) {
      ++dropped_out_of_range_;
    } else {
      ++total_points_;
    }
  }
  const std::size_t per_fragment = (max_datagram_bytes - kHeaderBytes - kTrailerBytes) / stride_;
  points_per_fragment_ = static_cast<std::uint16_t>(per_fragment > 0xFFFF ? 0xFFFF : per_fragment);
  const std::uint64_t fragments =
      total_points_ == 0 ? 1 : (static_cast<std::uint64_t>(total_points_) + points_per_fragment_ - 1) / points_per_fragment_;
  if (fragments > 0xFFFF) return CloudStatus::kInvalidArgument;
  fragment_count_ = static_cast<std::uint16_t>(fragments);
  started_ = true;
  return CloudStatus::kOk;
}

CloudStatus PointCloudFragmenter::next(std::span<std::uint8_t> out, std::size_t& written) {
  written = 0;
  if (!started_) return CloudStatus::kInvalidArgument;
  if (next_fragment_ >= fragment_count_) return CloudStatus::kDone;
  const std::uint32_t count = expected_points(total_points_, points_per_fragment_, next_fragment_);
  const std::size_t payload = count * stride_;
  const std::size_t size = kHeaderBytes + payload + kTrailerBytes;
  if (out.size() < size) return CloudStatus::kBufferTooSmall;

  CloudFragmentHeader h;
  h.info = info_;
  h.flags = flags_;
  h.fragment_index = next_fragment_;
  h.fragment_count = fragment_count_;
  h.points_in_fragment = static_cast<std::uint16_t>(count);
  h.points_per_fragment = points_per_fragment_;
  h.total_points = total_points_;
  h.payload_bytes = static_cast<std::uint16_t>(payload);
  std::uint8_t* p = out.data();
  write_header(p, h);

  std::uint8_t* w = p + kHeaderBytes;
  const std::size_t n = points_.xyz.size() / 3;
  std::uint32_t packed = 0;
  const double scale = static_cast<double>(info_.scale_m);
  while (packed < count && source_cursor_ < n) {
    const std::size_t i = source_cursor_++;
    const float* v = &points_.xyz[3 * i];
    // Within [-max_abs_, max_abs_] (so finite) exactly when quantize_coordinate() accepts the
    // coordinate, and then it returns this rounding. Other points were counted in begin().
    if (!(std::fabs(v[0]) <= max_abs_ && std::fabs(v[1]) <= max_abs_ && std::fabs(v[2]) <= max_abs_)) continue;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const auto q = static_cast<std::int32_t>(round_half_away_to_integer(static_cast<double>(v[axis]) / scale));
      if (info_.width == CoordWidth::kInt16) {
        put_u16(w, static_cast<std::uint16_t>(static_cast<std::int16_t>(q)));
        w += 2;
      } else {
        put_u32(w, static_cast<std::uint32_t>(q));
        w += 4;
      }
    }
    if (flags_ & cloud_flags::kIntensity) put_u8(w++, points_.intensity[i]);
    if (flags_ & cloud_flags::kPointTime) {
      put_u16(w, points_.time_offset_ticks[i]);
      w += 2;
    }
    ++packed;
  }
  if (packed != count) return CloudStatus::kInvalidArgument;  // input changed since begin()
  put_u32(w, crc32(std::span<const std::uint8_t>(p, kHeaderBytes + payload)));
  written = size;
  ++next_fragment_;
  return CloudStatus::kOk;
}

// ---------------------------------------------------------------------------------------------
// Parsing

CloudStatus parse_cloud_fragment(std::span<const std::uint8_t> datagram, CloudFragmentHeader& h,
                                 std::span<const std::uint8_t>& payload) {
  const std::uint8_t* p = datagram.data();
  if (datagram.size() < kHeaderBytes + kTrailerBytes) return CloudStatus::kTruncated;
  if (get_u32(p + kOffMagic) != kMagic) return CloudStatus::kBadMagic;
  if (p[kOffVersion] != kVersion || get_u16(p + kOffHeaderBytes) != kHeaderBytes) {
    return CloudStatus::kUnsupported;
  }
  h.payload_bytes = get_u16(p + kOffPayloadBytes);
  const std::size_t size = kHeaderBytes + h.payload_bytes + kTrailerBytes;
  if (datagram.size() < size) return CloudStatus::kTruncated;
  if (datagram.size() > size) return CloudStatus::kMalformed;
  const std::uint32_t crc = crc32(datagram.first(kHeaderBytes + h.payload_bytes));
  if (crc != get_u32(p + kHeaderBytes + h.payload_bytes)) return CloudStatus::kBadCrc;

  const std::uint8_t type = p[kOffType];
  h.flags = get_u16(p + kOffFlags);
  if ((type != static_cast<std::uint8_t>(CloudMessageType::kEgoScan) &&
       type != static_cast<std::uint8_t>(CloudMessageType::kMapShare)) ||
      (h.flags & ~cloud_flags::kKnownMask) != 0) {
    return CloudStatus::kUnsupported;
  }
  h.info.type = static_cast<CloudMessageType>(type);
  h.info.width = (h.flags & cloud_flags::kCoordsInt32) ? CoordWidth::kInt32 : CoordWidth::kInt16;
  h.info.sensor_id = get_u16(p + kOffSensorId);
  h.info.sender_id = get_u32(p + kOffSenderId);
  h.info.frame_seq = get_u32(p + kOffFrameSeq);
  h.fragment_index = get_u16(p + kOffFragIndex);
  h.fragment_count = get_u16(p + kOffFragCount);
  h.info.timestamp_ns = get_u64(p + kOffTimestamp);
  bool finite = true;
  for (int i = 0; i < 3; ++i) {
    h.info.pose.position_m[i] = get_f64(p + kOffPosition + 8 * i);
    finite = finite && std::isfinite(h.info.pose.position_m[i]);
  }
  for (int i = 0; i < 4; ++i) {
    h.info.pose.quaternion_xyzw[i] = get_f64(p + kOffQuaternion + 8 * i);
    finite = finite && std::isfinite(h.info.pose.quaternion_xyzw[i]);
  }
  h.info.scale_m = get_f32(p + kOffScale);
  h.points_in_fragment = get_u16(p + kOffPointsInFrag);
  h.points_per_fragment = get_u16(p + kOffPointsPerFrag);
  h.total_points = get_u32(p + kOffTotalPoints);

  // Counts must agree with each other: a sender cannot claim overlapping or out-of-range points.
  if (!finite || !std::isfinite(h.info.scale_m) || !(h.info.scale_m > 0.0f)) return CloudStatus::kMalformed;
  if (h.points_per_fragment == 0 || h.fragment_count == 0 || h.fragment_index >= h.fragment_count) {
    return CloudStatus::kMalformed;
  }
  const std::uint64_t fragments =
      h.total_points == 0 ? 1 : (static_cast<std::uint64_t>(h.total_points) + h.points_per_fragment - 1) / h.points_per_fragment;
  if (fragments != h.fragment_count) return CloudStatus::kMalformed;
  if (h.points_in_fragment != expected_points(h.total_points, h.points_per_fragment, h.fragment_index)) {
    return CloudStatus::kMalformed;
  }
  if (static_cast<std::size_t>(h.points_in_fragment) * cloud_point_stride(h.flags) != h.payload_bytes) {
    return CloudStatus::kMalformed;
  }
  payload = datagram.subspan(kHeaderBytes, h.payload_bytes);
  return CloudStatus::kOk;
}

// ---------------------------------------------------------------------------------------------
// Reassembler

PointCloudReassembler::PointCloudReassembler(const Storage& storage, const ReassemblyConfig& config)
    : storage_(storage), config_(config) {
  // Storage that does not match the declared capacity is shrunk to what the spans can hold,
  // so a mis-sized caller buffer degrades capacity instead of overrunning.
  const std::size_t slots = storage_.slots.size();
  if (slots == 0) return;
  std::size_t max_points = storage_.max_points;
  if (storage_.xyz.size() / (3 * slots) < max_points) max_points = storage_.xyz.size() / (3 * slots);
  if (storage_.intensity.size() / slots < max_points) max_points = storage_.intensity.size() / slots;
  if (storage_.time_ticks.size() / slots < max_points) max_points = storage_.time_ticks.size() / slots;
  storage_.max_points = static_cast<std::uint32_t>(max_points);
  const std::size_t words = storage_.bitmaps.size() / slots;
  if (words * 64 < storage_.max_fragments) storage_.max_fragments = static_cast<std::uint16_t>(words * 64);
  reset();
}

std::size_t PointCloudReassembler::bitmap_words() const { return (storage_.max_fragments + 63u) / 64u; }

void PointCloudReassembler::reset() {
  for (auto& slot : storage_.slots) slot = ReassemblySlot{};
  for (auto& key : recent_) key = FrameKey{};
  recent_next_ = 0;
  counters_ = ReassemblyCounters{};
  completed_ = ReassembledCloud{};
  last_accepted_ = AcceptedFragment{};
  completed_slot_ = SIZE_MAX;
}

std::size_t PointCloudReassembler::frames_in_flight() const {
  std::size_t n = 0;
  for (const auto& slot : storage_.slots) n += slot.state == ReassemblySlot::State::kFilling ? 1 : 0;
  return n;
}

CloudStatus PointCloudReassembler::count(CloudStatus status) {
  switch (status) {
    case CloudStatus::kOk: ++counters_.fragments_accepted; break;
    case CloudStatus::kFrameComplete: ++counters_.fragments_accepted; ++counters_.frames_completed; break;
    case CloudStatus::kDuplicate: ++counters_.duplicates; break;
    case CloudStatus::kStaleFrame: ++counters_.stale_fragments; break;
    case CloudStatus::kTruncated: ++counters_.truncated; break;
    case CloudStatus::kBadMagic: ++counters_.bad_magic; break;
    case CloudStatus::kUnsupported: ++counters_.unsupported; break;
    case CloudStatus::kBadCrc: ++counters_.bad_crc; break;
    case CloudStatus::kMalformed: ++counters_.malformed; break;
    case CloudStatus::kInconsistent: ++counters_.inconsistent; break;
    case CloudStatus::kCapacityExceeded: ++counters_.over_capacity; break;
    default: break;
  }
  return status;
}

void PointCloudReassembler::release_completed() {
  if (completed_slot_ < storage_.slots.size()) storage_.slots[completed_slot_] = ReassemblySlot{};
  completed_slot_ = SIZE_MAX;
  completed_ = ReassembledCloud{};
}

void PointCloudReassembler::remember_finished(const CloudFragmentHeader& meta) {
  recent_[recent_next_] = FrameKey{meta.info.sender_id, meta.info.sensor_id, meta.info.frame_seq, true};
  recent_next_ = (recent_next_ + 1) % kRecentKeys;
}

bool PointCloudReassembler::recently_finished(const CloudFragmentHeader& meta) const {
  for (const auto& key : recent_) {
    if (key.valid && key.sender_id == meta.info.sender_id && key.sensor_id == meta.info.sensor_id &&
        key.frame_seq == meta.info.frame_seq) {
      return true;
    }
  }
  return false;
}

std::size_t PointCloudReassembler::find_slot(const CloudFragmentHeader& meta) const {
  for (std::size_t i = 0; i < storage_.slots.size(); ++i) {
    const auto& slot = storage_.slots[i];
    if (slot.state == ReassemblySlot::State::kFilling && slot.meta.info.sender_id == meta.info.sender_id &&
        slot.meta.info.sensor_id == meta.info.sensor_id && slot.meta.info.frame_seq == meta.info.frame_seq) {
      return i;
    }
  }
  return SIZE_MAX;
}

std::size_t PointCloudReassembler::claim_slot(std::int64_t now_ns) {
  (void)now_ns;
  std::size_t oldest = SIZE_MAX;
  for (std::size_t i = 0; i < storage_.slots.size(); ++i) {
    const auto& slot = storage_.slots[i];
    if (slot.state == ReassemblySlot::State::kFree) return i;
    if (slot.state == ReassemblySlot::State::kFilling &&
        (oldest == SIZE_MAX || slot.first_rx_ns < storage_.slots[oldest].first_rx_ns)) {
      oldest = i;
    }
  }
  if (oldest != SIZE_MAX) {
    ++counters_.frames_evicted;
    remember_finished(storage_.slots[oldest].meta);
    storage_.slots[oldest] = ReassemblySlot{};
  }
  return oldest;
}

std::size_t PointCloudReassembler::expire(std::int64_t now_ns) {
  std::size_t dropped = 0;
  for (auto& slot : storage_.slots) {
    if (slot.state == ReassemblySlot::State::kFilling && now_ns - slot.first_rx_ns > config_.frame_timeout_ns) {
      remember_finished(slot.meta);
      slot = ReassemblySlot{};
      ++counters_.frames_timed_out;
      ++dropped;
    }
  }
  return dropped;
}

void PointCloudReassembler::open_slot(std::size_t index, const CloudFragmentHeader& h, std::int64_t now_ns) {
  ReassemblySlot& fresh = storage_.slots[index];
  fresh.state = ReassemblySlot::State::kFilling;
  fresh.meta = h;
  fresh.first_rx_ns = now_ns;
  for (std::size_t w = 0; w < bitmap_words(); ++w) storage_.bitmaps[index * bitmap_words() + w] = 0;
}

namespace {

// Where a cloud's points go in a slot: all of them in order, or, for a cloud of more points than
// the slot holds, `kept` of them evenly spread over the cloud at their rank among the kept
// (even_thinning.hpp: by the point's index alone, so fragments may arrive in any order), so the
// whole sweep arrives at a lower density instead of its first sectors only.
struct PointPlacement {
  std::uint64_t total = 0, kept = 0;
  bool thins() const { return kept < total; }
  bool keeps(std::uint64_t i) const { return !thins() || kept_evenly(i, total, kept); }
  std::uint64_t rank(std::uint64_t i) const { return thins() ? kept_rank(i, total, kept) : i; }
};

PointPlacement placement_of(const CloudFragmentHeader& h, std::uint32_t max_points) {
  return {h.total_points, h.total_points < max_points ? h.total_points : max_points};
}

// The points of one fragment (global indices first..first+count) into a slot's arrays. The
// coordinate width is a template parameter so the per-coordinate loop has no branch on it
// (decoding was a tenth of the firmware's non-localizer time).
template <bool Wide>
void decode_fragment(const std::uint8_t* r, std::size_t count, std::uint16_t flags, double scale,
                     const PointPlacement& place, std::uint64_t first, float* xyz, std::uint8_t* intensity,
                     std::uint16_t* time_ticks) {
  const bool with_intensity = (flags & cloud_flags::kIntensity) != 0;
  const bool with_time = (flags & cloud_flags::kPointTime) != 0;
  const std::size_t stride = cloud_point_stride(flags);
  const auto coordinate = [&r, scale] {
    const std::int32_t q = Wide ? static_cast<std::int32_t>(get_u32(r)) : static_cast<std::int16_t>(get_u16(r));
    r += Wide ? 4 : 2;
    return static_cast<float>(static_cast<double>(q) * scale);
  };
  for (std::size_t k = 0; k < count; ++k) {
    if (!place.keeps(first + k)) {
      r += stride;
      continue;
    }
    const std::size_t d = static_cast<std::size_t>(place.rank(first + k));
    xyz[3 * d] = coordinate();
    xyz[3 * d + 1] = coordinate();
    xyz[3 * d + 2] = coordinate();
    if (with_intensity) intensity[d] = *r++;
    if (with_time) {
      time_ticks[d] = get_u16(r);
      r += 2;
    }
  }
}

}  // namespace

// Decodes straight into the slot; parse_cloud_fragment() guaranteed first + count <= total.
void PointCloudReassembler::decode_points(std::size_t index, const CloudFragmentHeader& h,
                                          std::span<const std::uint8_t> payload) {
  const std::size_t base = static_cast<std::size_t>(index) * storage_.max_points;
  const std::uint64_t first = static_cast<std::uint64_t>(h.fragment_index) * h.points_per_fragment;
  const PointPlacement place = placement_of(h, storage_.max_points);
  const double scale = static_cast<double>(h.info.scale_m);
  float* xyz = storage_.xyz.data() + 3 * base;
  std::uint8_t* intensity = storage_.intensity.data() + base;
  std::uint16_t* time_ticks = storage_.time_ticks.data() + base;
  if (h.flags & cloud_flags::kCoordsInt32) {
    decode_fragment<true>(payload.data(), h.points_in_fragment, h.flags, scale, place, first, xyz, intensity, time_ticks);
  } else {
    decode_fragment<false>(payload.data(), h.points_in_fragment, h.flags, scale, place, first, xyz, intensity, time_ticks);
  }
}

void PointCloudReassembler::publish_completed(std::size_t index, std::int64_t now_ns) {
  ReassemblySlot& slot = storage_.slots[index];
  const std::size_t base = static_cast<std::size_t>(index) * storage_.max_points;
  slot.state = ReassemblySlot::State::kComplete;
  remember_finished(slot.meta);
  completed_slot_ = index;
  completed_.info = slot.meta.info;
  const std::size_t points = static_cast<std::size_t>(placement_of(slot.meta, storage_.max_points).kept);
  completed_.point_count = static_cast<std::uint32_t>(points);
  completed_.points_thinned = slot.meta.total_points - completed_.point_count;
  completed_.xyz = std::span<const float>(storage_.xyz).subspan(3 * base, 3 * points);
  completed_.intensity = (slot.meta.flags & cloud_flags::kIntensity)
                             ? std::span<const std::uint8_t>(storage_.intensity).subspan(base, points)
                             : std::span<const std::uint8_t>{};
  completed_.time_offset_ticks = (slot.meta.flags & cloud_flags::kPointTime)
                                  ? std::span<const std::uint16_t>(storage_.time_ticks).subspan(base, points)
                                  : std::span<const std::uint16_t>{};
  counters_.points_thinned += completed_.points_thinned;
  completed_.first_fragment_rx_ns = slot.first_rx_ns;
  completed_.completed_rx_ns = now_ns;
  completed_.flags = slot.meta.flags;
  completed_.fragment_count = slot.meta.fragment_count;
  completed_.points_per_fragment = slot.meta.points_per_fragment;
  completed_.slot = index;
}

CloudStatus PointCloudReassembler::push(std::span<const std::uint8_t> datagram, std::int64_t now_ns) {
  release_completed();
  last_accepted_ = AcceptedFragment{};
  ++counters_.datagrams;
  expire(now_ns);

  CloudFragmentHeader h;
  std::span<const std::uint8_t> payload;
  const CloudStatus parsed = parse_cloud_fragment(datagram, h, payload);
  if (parsed != CloudStatus::kOk) return count(parsed);
  if (storage_.slots.empty() || h.fragment_count > storage_.max_fragments) {
    return count(CloudStatus::kCapacityExceeded);
  }

  std::size_t index = find_slot(h);
  const bool opened = index == SIZE_MAX;
  if (index != SIZE_MAX) {
    if (!same_frame(storage_.slots[index].meta, h)) return count(CloudStatus::kInconsistent);
  } else {
    if (recently_finished(h)) return count(CloudStatus::kStaleFrame);
    index = claim_slot(now_ns);
    if (index == SIZE_MAX) return count(CloudStatus::kCapacityExceeded);
    open_slot(index, h, now_ns);
  }
  std::uint64_t& word = storage_.bitmaps[index * bitmap_words() + h.fragment_index / 64u];
  const std::uint64_t bit = std::uint64_t{1} << (h.fragment_index % 64u);
  if (word & bit) return count(CloudStatus::kDuplicate);
  word |= bit;

  decode_points(index, h, payload);
  ReassemblySlot& slot = storage_.slots[index];
  slot.points_received += h.points_in_fragment;
  ++slot.fragments_received;
  last_accepted_ = AcceptedFragment{true, index, h.fragment_index, h.info.type, payload, opened, h.info.sender_id,
                                    h.info.timestamp_ns};
  if (slot.fragments_received < slot.meta.fragment_count) return count(CloudStatus::kOk);
  publish_completed(index, now_ns);
  return count(CloudStatus::kFrameComplete);
}

}  // namespace v2xloc::protocol
