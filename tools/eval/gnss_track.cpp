#include "tools/eval/gnss_track.hpp"

#include <cmath>

#include "firmware/protocol/can_messages.hpp"
#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::eval {
namespace {

// The GNSS fixes of the recording's CAN log (a latitude and longitude paired by the codec's
// GnssPositionPairer, status and time frames of one stamp; valid = 2D/3D fix), in ENU minus the
// lever arm. The log is the recorded sender's: no counter checks here.
class GnssTrack {
 public:
  GnssTrack(const GeodeticOrigin& origin, const Eigen::Vector3d& lever) : origin_(origin), lever_(lever) {}

  void push(const sim::CanLogFrame& f) {
    hal::CanFrame frame;
    frame.id = f.id;
    frame.dlc = f.dlc;
    for (int b = 0; b < 8; ++b) frame.data[b] = f.data[b];
    if (f.id == protocol::kGnssPositionId) {
      protocol::GnssPosition half;
      if (protocol::unpack(frame, half) != protocol::DecodeStatus::kOk) return;
      const bool paired = pairer_.push(half) == protocol::GnssPositionPairer::Result::kPaired;
      position_t_ = paired ? f.t : -1.0;
    } else if (f.id == protocol::kGnssStatusId) {
      if (protocol::unpack(frame, status_) == protocol::DecodeStatus::kOk) status_t_ = f.t;
    } else if (f.id == protocol::kGnssTimeId) {
      protocol::GnssTime time;
      if (protocol::unpack(frame, time) != protocol::DecodeStatus::kOk) return;
      pairer_.end_fix();
      if (std::abs(position_t_ - f.t) > 1e-4 || std::abs(status_t_ - f.t) > 1e-4) return;
      const bool valid = status_.fix_type == protocol::GnssFixType::kFix3D ||
                         status_.fix_type == protocol::GnssFixType::kFix2D;
      if (!valid) return;
      const Vec3d enu = geodetic_to_enu(origin_, GeodeticPoint{pairer_.lat_deg(), pairer_.lon_deg(), status_.alt_m});
      body_ = enu - lever_;  // roll = pitch = 0: the lever is vertical
      has_fix_ = true;
    }
  }
  bool has_fix() const { return has_fix_; }
  const Eigen::Vector3d& body() const { return body_; }

 private:
  GeodeticOrigin origin_;
  Eigen::Vector3d lever_;
  protocol::GnssPositionPairer pairer_{};
  protocol::GnssStatus status_{};
  double position_t_ = -1.0, status_t_ = -2.0;
  bool has_fix_ = false;
  Eigen::Vector3d body_ = Eigen::Vector3d::Zero();
};

}  // namespace

bool fill_gnss(const sim::RecordingReader& reader, const Eigen::Vector3d& gnss_antenna_in_body,
               std::vector<FrameRecord>& records, std::string& error) {
  std::vector<sim::CanLogFrame> can;
  if (!reader.can_frames(can, error)) return false;
  GnssTrack gnss(make_geodetic_origin(reader.origin_lat_deg(), reader.origin_lon_deg(), reader.origin_alt_m()),
                 gnss_antenna_in_body);
  std::size_t next_can = 0;
  for (FrameRecord& rec : records) {
    for (; next_can < can.size() && can[next_can].t <= rec.t + 1e-9; ++next_can) gnss.push(can[next_can]);
    rec.has_gnss = gnss.has_fix();
    rec.gnss_body = gnss.body();
  }
  return true;
}

}  // namespace v2xloc::eval
