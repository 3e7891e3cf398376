// UDP point-cloud protocol v1: ego scans and V2X map shares, fragmented into datagrams of at most
// 1400 bytes, quantized coordinates, CRC-32 trailer. Byte layout: firmware/WIRE_FORMATS.md,
// section "UDP point clouds". Allocation-free, exception-free: fragmenter writes into caller
// buffers, reassembler works over static (caller-owned or in-type) storage.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace v2xloc::protocol {

namespace pointcloud_wire {
inline constexpr std::uint32_t kMagic = 0x50583256u;  // bytes 'V','2','X','P' on the wire
inline constexpr std::uint8_t kVersion = 1;
inline constexpr std::size_t kHeaderBytes = 104;
inline constexpr std::size_t kTrailerBytes = 4;  // CRC-32 over header + payload
inline constexpr std::size_t kMaxDatagramBytes = 1400;
inline constexpr std::size_t kMaxPayloadBytes = kMaxDatagramBytes - kHeaderBytes - kTrailerBytes;
inline constexpr std::int32_t kInt16Limit = 32767;          // -32768 is never sent (symmetric range)
inline constexpr std::int32_t kInt32Limit = 2147483647;     // likewise INT32_MIN
}  // namespace pointcloud_wire

enum class CloudMessageType : std::uint8_t { kEgoScan = 1, kMapShare = 2 };

enum class CoordWidth : std::uint8_t { kInt16 = 2, kInt32 = 4 };

// Header flag bits; any other bit set -> the datagram is rejected (kUnsupported).
namespace cloud_flags {
inline constexpr std::uint16_t kIntensity = 1u << 0;   // uint8 per point
inline constexpr std::uint16_t kPointTime = 1u << 1;   // uint16 ticks of kPointTimeTick after timestamp_ns
inline constexpr std::uint16_t kCoordsInt32 = 1u << 2; // int32 coordinates (else int16)
inline constexpr std::uint16_t kKnownMask = kIntensity | kPointTime | kCoordsInt32;
}  // namespace cloud_flags

enum class CloudStatus : std::uint8_t {
  kOk,                // fragment produced / accepted, frame not yet complete
  kDone,              // fragmenter: no more fragments
  kFrameComplete,     // reassembler: this fragment completed a frame (see completed())
  kDuplicate,         // fragment already received for an in-flight frame: ignored, counted
  kStaleFrame,        // fragment of a frame already completed or evicted: ignored, counted
  kBufferTooSmall,    // caller buffer cannot hold one fragment
  kInvalidArgument,   // bad fragmenter input (scale <= 0, span sizes disagree, too many points)
  kTruncated,         // datagram shorter than its header or its declared payload
  kBadMagic,
  kUnsupported,       // unknown version, header size, message type or flag bits
  kBadCrc,
  kMalformed,         // fields that contradict each other (lying counts, indices out of range)
  kInconsistent,      // fragment disagrees with earlier fragments of the same frame
  kCapacityExceeded,  // frame larger than the reassembler's static capacity
};

const char* to_string(CloudStatus status);

// Sensor pose in the sender's reference frame (global frame for map shares, vehicle frame or
// global frame for ego scans, per the stream's calibration). Quaternion in x, y, z, w order.
// One tick of the per-point time field: 4 us, so a u16 spans 262 ms and covers a full 10 Hz
// sweep (100 ms) with margin; the 2 us quantization error is 0.03 mm of motion at 15 m/s.
inline constexpr double kPointTimeTick = 4e-6;  // [s]

struct SensorPose {
  double position_m[3] = {0.0, 0.0, 0.0};
  double quaternion_xyzw[4] = {0.0, 0.0, 0.0, 1.0};
};

struct CloudFrameInfo {
  CloudMessageType type = CloudMessageType::kEgoScan;
  std::uint32_t sender_id = 0;
  std::uint16_t sensor_id = 0;
  std::uint32_t frame_seq = 0;
  std::uint64_t timestamp_ns = 0;  // sender's (disciplined) time of the scan start
  SensorPose pose;
  float scale_m = 0.002f;          // metres per quantization step
  CoordWidth width = CoordWidth::kInt16;
};

// Points in the sensor frame, metres. xyz.size() == 3 * n; intensity and time_offset_ticks are either
// empty (field absent on the wire) or exactly n long.
struct CloudPointsView {
  std::span<const float> xyz;
  std::span<const std::uint8_t> intensity;
  std::span<const std::uint16_t> time_offset_ticks;
};

// Quantize one coordinate; false when not finite or outside the symmetric range of `width`.
bool quantize_coordinate(float value_m, float scale_m, CoordWidth width, std::int32_t& out);

// For a finite scale_m > 0: the largest m such that quantize_coordinate() accepts exactly the
// values with |value| <= m (the accepted values are one interval, see the definition).
float largest_quantizable(float scale_m, CoordWidth width);

// Splits one frame into datagrams. All fragments but the last carry points_per_fragment points.
// Points that are not finite or fall outside the quantization range are dropped and counted;
// total_points on the wire is the number actually sent.
class PointCloudFragmenter {
 public:
  CloudStatus begin(const CloudFrameInfo& info, const CloudPointsView& points,
                    std::size_t max_datagram_bytes = pointcloud_wire::kMaxDatagramBytes);
  // Writes the next fragment into `out`; kDone once all fragments were produced.
  CloudStatus next(std::span<std::uint8_t> out, std::size_t& written);

  std::uint32_t total_points() const { return total_points_; }
  std::uint16_t fragment_count() const { return fragment_count_; }
  std::uint16_t points_per_fragment() const { return points_per_fragment_; }
  std::uint32_t dropped_out_of_range() const { return dropped_out_of_range_; }
  std::uint32_t dropped_non_finite() const { return dropped_non_finite_; }
  std::size_t point_stride_bytes() const { return stride_; }

 private:
  CloudFrameInfo info_{};
  CloudPointsView points_{};
  std::uint16_t flags_ = 0;
  std::size_t stride_ = 0;
  float max_abs_ = 0.0f;  // largest_quantizable() of the frame's scale and width
  std::size_t source_cursor_ = 0;
  std::uint32_t total_points_ = 0;
  std::uint16_t fragment_count_ = 0;
  std::uint16_t points_per_fragment_ = 0;
  std::uint16_t next_fragment_ = 0;
  std::uint32_t dropped_out_of_range_ = 0;
  std::uint32_t dropped_non_finite_ = 0;
  bool started_ = false;
};

// Decoded fixed header of one datagram (exposed for tools and tests).
struct CloudFragmentHeader {
  CloudFrameInfo info;
  std::uint16_t flags = 0;
  std::uint16_t fragment_index = 0;
  std::uint16_t fragment_count = 0;
  std::uint16_t points_in_fragment = 0;
  std::uint16_t points_per_fragment = 0;
  std::uint32_t total_points = 0;
  std::uint16_t payload_bytes = 0;
};

// Validates magic, version, sizes, CRC and internal consistency of a single datagram.
CloudStatus parse_cloud_fragment(std::span<const std::uint8_t> datagram, CloudFragmentHeader& header,
                                 std::span<const std::uint8_t>& payload);

std::size_t cloud_point_stride(std::uint16_t flags);

// A completed frame: points dequantized to float metres in the sensor frame.
struct ReassembledCloud {
  CloudFrameInfo info;
  std::uint32_t point_count = 0;                 // <= the reassembler's max_points
  std::uint32_t points_thinned = 0;              // sent points left out (evenly) to fit max_points
  std::span<const float> xyz;                    // 3 * point_count
  std::span<const std::uint8_t> intensity;       // empty when absent
  std::span<const std::uint16_t> time_offset_ticks; // empty when absent
  std::int64_t first_fragment_rx_ns = 0;
  std::int64_t completed_rx_ns = 0;
  // Frame-constant wire fields (what a digest over the wire bytes covers besides the payloads).
  std::uint16_t flags = 0;
  std::uint16_t fragment_count = 0;
  std::uint16_t points_per_fragment = 0;
  std::size_t slot = 0;  // reassembly slot the frame was built in (see AcceptedFragment)
};

// The fragment the last push() placed (kOk or kFrameComplete): its reassembly slot, index and
// payload bytes exactly as received (a view into the datagram passed to push()). Lets a caller
// hash what arrived per fragment without the reassembler knowing about hashing.
struct AcceptedFragment {
  bool valid = false;
  std::size_t slot = 0;
  std::uint16_t fragment_index = 0;
  CloudMessageType type = CloudMessageType::kEgoScan;
  std::span<const std::uint8_t> payload;
  bool opened_frame = false;       // the first fragment of its frame to arrive (the slot was opened for it)
  std::uint32_t sender_id = 0;     // the header's (self-declared) sender and time stamp
  std::uint64_t timestamp_ns = 0;
};

struct ReassemblyCounters {
  std::uint64_t datagrams = 0;
  std::uint64_t fragments_accepted = 0;
  std::uint64_t frames_completed = 0;
  std::uint64_t duplicates = 0;
  std::uint64_t stale_fragments = 0;      // for frames already completed / evicted
  std::uint64_t frames_timed_out = 0;     // incomplete frames dropped by age
  std::uint64_t frames_evicted = 0;       // incomplete frames dropped to make room
  std::uint64_t bad_crc = 0;
  std::uint64_t truncated = 0;
  std::uint64_t bad_magic = 0;
  std::uint64_t unsupported = 0;
  std::uint64_t malformed = 0;
  std::uint64_t inconsistent = 0;
  std::uint64_t over_capacity = 0;
  std::uint64_t points_thinned = 0;       // points of completed clouds over max_points, left out evenly
};

struct ReassemblyConfig {
  std::int64_t frame_timeout_ns = 200'000'000;  // incomplete frames older than this are dropped
};

// Book-keeping of one frame in flight (storage for its points lives in the spans below).
struct ReassemblySlot {
  enum class State : std::uint8_t { kFree, kFilling, kComplete };
  State state = State::kFree;
  CloudFragmentHeader meta{};
  std::uint32_t points_received = 0;
  std::uint16_t fragments_received = 0;
  std::int64_t first_rx_ns = 0;
};

// Size-free reassembler over caller storage: `slots.size()` frames in flight, each with
// max_points points and max_fragments fragment bits. Not thread-safe (one owner polls it).
class PointCloudReassembler {
 public:
  struct Storage {
    std::span<ReassemblySlot> slots;
    std::span<float> xyz;                  // slots * 3 * max_points
    std::span<std::uint8_t> intensity;     // slots * max_points
    std::span<std::uint16_t> time_ticks;      // slots * max_points
    std::span<std::uint64_t> bitmaps;      // slots * ceil(max_fragments / 64)
    std::uint32_t max_points = 0;
    std::uint16_t max_fragments = 0;
  };

  PointCloudReassembler(const Storage& storage, const ReassemblyConfig& config);

  // Feed one datagram received at `now_ns` (monotonic). On kFrameComplete, completed() is valid
  // until the next push() / expire() / reset().
  CloudStatus push(std::span<const std::uint8_t> datagram, std::int64_t now_ns);
  // Drops incomplete frames older than the timeout. Returns how many were dropped.
  std::size_t expire(std::int64_t now_ns);
  const ReassembledCloud& completed() const { return completed_; }
  const AcceptedFragment& last_accepted() const { return last_accepted_; }
  const ReassemblyCounters& counters() const { return counters_; }
  std::size_t frames_in_flight() const;
  void reset();  // frees every slot and clears the counters

 private:
  struct FrameKey {
    std::uint32_t sender_id = 0;
    std::uint16_t sensor_id = 0;
    std::uint32_t frame_seq = 0;
    bool valid = false;
  };
  static constexpr std::size_t kRecentKeys = 32;

  CloudStatus count(CloudStatus status);
  void release_completed();
  void remember_finished(const CloudFragmentHeader& meta);
  bool recently_finished(const CloudFragmentHeader& meta) const;
  std::size_t find_slot(const CloudFragmentHeader& meta) const;
  std::size_t claim_slot(std::int64_t now_ns);
  std::size_t bitmap_words() const;
  // A claimed slot starts filling frame h: header kept, fragment bits cleared.
  void open_slot(std::size_t index, const CloudFragmentHeader& h, std::int64_t now_ns);
  // Dequantizes fragment h's points into slot `index`'s storage.
  void decode_points(std::size_t index, const CloudFragmentHeader& h, std::span<const std::uint8_t> payload);
  // Slot `index` holds a whole frame: completed() describes it until the next push.
  void publish_completed(std::size_t index, std::int64_t now_ns);

  Storage storage_;
  ReassemblyConfig config_;
  ReassemblyCounters counters_{};
  ReassembledCloud completed_{};
  AcceptedFragment last_accepted_{};
  std::size_t completed_slot_ = SIZE_MAX;
  std::array<FrameKey, kRecentKeys> recent_{};
  std::size_t recent_next_ = 0;
};

namespace detail {
template <std::size_t Slots, std::size_t MaxPoints, std::size_t MaxFragments>
struct ReassemblerArrays {
  std::array<ReassemblySlot, Slots> slots{};
  std::array<float, Slots * MaxPoints * 3> xyz{};
  std::array<std::uint8_t, Slots * MaxPoints> intensity{};
  std::array<std::uint16_t, Slots * MaxPoints> time_ticks{};
  std::array<std::uint64_t, Slots * ((MaxFragments + 63) / 64)> bitmaps{};
};
}  // namespace detail

// Capacity in the type. Large: declare it static (or as a member of a static object).
template <std::size_t Slots, std::size_t MaxPoints, std::size_t MaxFragments>
class StaticPointCloudReassembler : private detail::ReassemblerArrays<Slots, MaxPoints, MaxFragments>,
                                    public PointCloudReassembler {
  static_assert(Slots > 0 && MaxPoints > 0 && MaxFragments > 0 && MaxFragments <= 65535);
  using Arrays = detail::ReassemblerArrays<Slots, MaxPoints, MaxFragments>;

 public:
  explicit StaticPointCloudReassembler(const ReassemblyConfig& config = {})
      : Arrays(),
        PointCloudReassembler(Storage{Arrays::slots, Arrays::xyz, Arrays::intensity, Arrays::time_ticks,
                                      Arrays::bitmaps, static_cast<std::uint32_t>(MaxPoints),
                                      static_cast<std::uint16_t>(MaxFragments)},
                              config) {}
};

}  // namespace v2xloc::protocol
