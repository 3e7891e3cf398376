// Wire -> localizer inputs, the period driver's one entry point: it owns the three parts and
// routes between them.
//   CanInputDecoder (can_input_decoder.hpp): CAN frames -> vehicle inputs and GNSS fixes;
//   CloudInputDecoder (cloud_input_decoder.hpp): datagrams -> reassembled clouds, ego scans;
//   ShareVerificationQueue (share_verification_queue.hpp): map shares -> verified map clouds;
//   ImuInputDecoder (imu_input_decoder.hpp): HID IMU reports -> IMU samples, queued in time order.
// The decoder RETURNS typed inputs and never calls the localizer: the period driver
// (period_driver.hpp) does, for the firmware loop, the replayer's in-process path and the
// offline evaluator alike, so every path applies exactly the firmware's decoding and checks.
//
// Input order (the firmware's contract; every other path follows it): a completed cloud is handed
// to the localizer only after every CAN frame received before its last fragment, so per ego frame
// the localizer sees CAN inputs (receive order), then the IMU samples received up to the scan's
// completion (time order), then map clouds, then the ego scan.
// Allocation-free; all storage (reassembler, decoded cloud, share queue) is inside: make the object static.
#pragma once

#include <cstdint>
#include <span>

#include "firmware/wire/can_input_decoder.hpp"
#include "firmware/wire/cloud_input_decoder.hpp"
#include "firmware/wire/imu_input_decoder.hpp"
#include "firmware/wire/share_verification_queue.hpp"

namespace v2xloc::firmware {

class InputDecoder {
 public:
  // epoch_ns: disciplined time that maps to localizer time 0 (see localizer_time_s).
  explicit InputDecoder(std::int64_t epoch_ns = 0) : can_(epoch_ns), clouds_(epoch_ns), imu_(epoch_ns) {}
  void set_epoch_ns(std::int64_t epoch_ns) {
    can_.set_epoch_ns(epoch_ns);
    clouds_.set_epoch_ns(epoch_ns);
    imu_.set_epoch_ns(epoch_ns);
  }
  std::int64_t epoch_ns() const { return clouds_.epoch_ns(); }
  // Provisioned trust list (start-up). Without one, every map share is refused (unknown signer).
  void provision_trust(const trust::TrustList& list) { shares_.provision_trust(list); }
  // See ShareVerificationQueue::set_share_filter (the period driver installs the localizer).
  void set_share_filter(const MapShareWanted* wanted) { shares_.set_share_filter(wanted); }

  // One CAN frame received at disciplined time time_ns.
  DecodedCan decode_can(const hal::CanFrame& frame, std::int64_t time_ns) { return can_.decode(frame, time_ns); }

  // One HID IMU input report received at disciplined time time_ns; a sample waits in the IMU
  // queue until the period driver hands it on.
  ImuReportKind decode_imu(std::span<const std::uint8_t> report, std::int64_t time_ns) {
    return imu_.decode(report, time_ns);
  }

  // One datagram received at monotonic now_ns. True when it completed a cloud: the caller first
  // drains earlier inputs (CAN), then calls decode_completed() before the next datagram.
  // local_time_ns: the disciplined clock now (freshness of map shares and ego scans).
  bool on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns, std::int64_t local_time_ns,
                   DatagramChannel channel);
  // Emulation / offline convenience: local time = epoch + now_ns (the SimClock's relation), and
  // the channel taken from the datagram's message type (an offline event stream has no sockets).
  bool on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns) {
    return on_datagram(datagram, now_ns, epoch_ns() + now_ns, CloudInputDecoder::channel_of(datagram));
  }
  // The cloud the last datagram completed, as a localizer input (kNone when there is none; a
  // cloud is returned once). A map share goes to the verification queue (kMapQueued, kMapPaced or
  // kRejected); an ego scan (kEgoScan or kEgoRejected) opens a new verification period at the
  // local time of its completion.
  DecodedCloud decode_completed();
  // The same, with the local (disciplined) clock read again after the caller drained the CAN
  // frames received before the cloud's last fragment (the emulated clock moves with them).
  DecodedCloud decode_completed(std::int64_t local_time_ns);
  // Period boundary work (ShareVerificationQueue::next_verified_share).
  DecodedCloud next_verified_share(const MapShareWanted* wanted = nullptr) { return shares_.next_verified_share(wanted); }
  // The period's trust work (ShareVerificationQueue::take_trust_work).
  double take_trust_work() { return shares_.take_trust_work(); }
  // Frees idle reassembly slots and unmatched signatures (monotonic now_ns); returns the slots freed.
  std::size_t expire(std::int64_t now_ns) {
    shares_.expire(now_ns);
    return clouds_.expire(now_ns);
  }

  const CanInputDecoder& can() const { return can_; }
  const CloudInputDecoder& clouds() const { return clouds_; }
  const ShareVerificationQueue& shares() const { return shares_; }
  ShareVerificationQueue& shares() { return shares_; }
  const ImuInputDecoder& imu() const { return imu_; }
  ImuInputDecoder& imu() { return imu_; }

 private:
  // A cloud as CloudInputDecoder completed it, routed: a map share to the queue; an ego scan opens
  // a period and carries the GNSS flag.
  DecodedCloud route_completed(DecodedCloud cloud);

  CanInputDecoder can_;
  CloudInputDecoder clouds_;
  ShareVerificationQueue shares_;
  ImuInputDecoder imu_;
};

}  // namespace v2xloc::firmware
