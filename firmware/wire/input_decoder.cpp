#include "firmware/wire/input_decoder.hpp"

namespace v2xloc::firmware {

bool InputDecoder::on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns, std::int64_t local_time_ns,
                               DatagramChannel channel) {
  const DatagramResult r = clouds_.on_datagram(datagram, now_ns, local_time_ns, channel);
  if (r.signature) shares_.on_signature_datagram(datagram, now_ns);
  if (r.share_fragment != nullptr) shares_.on_share_fragment(*r.share_fragment, r.share_t);
  return r.completed;
}

DecodedCloud InputDecoder::decode_completed() { return route_completed(clouds_.decode_completed()); }

DecodedCloud InputDecoder::decode_completed(std::int64_t local_time_ns) {
  return route_completed(clouds_.decode_completed(local_time_ns));
}

DecodedCloud InputDecoder::route_completed(DecodedCloud cloud) {
  switch (cloud.kind) {
    case CloudKind::kMapShare:
      return shares_.queue(clouds_.completed_cloud(), cloud.map.world_T_sensor.matrix(), cloud.map.t);
    case CloudKind::kEgoScan:
      cloud.gnss_used = can_.take_gnss_fix_seen();
      shares_.begin_period(clouds_.completed_local_time_ns());  // an ego scan is the period boundary
      return cloud;
    case CloudKind::kEgoRejected:
      shares_.begin_period(clouds_.completed_local_time_ns());  // refused for its time, still a boundary
      return cloud;
    default: return cloud;
  }
}

}  // namespace v2xloc::firmware
