// One GNSS fix from its CAN frames: the 0x130 latitude and longitude halves (paired only when
// consecutive, protocol::GnssPositionPairer), 0x131 status, 0x133 velocity and 0x134 DOP are held
// until the 0x132 time frame closes the fix. Only frames that passed the codec's CRC, range and
// rolling-counter checks come here (CanInputDecoder). Allocation-free.
#pragma once

#include <cstdint>

#include "firmware/protocol/can_messages.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

class GnssFixAssembler {
 public:
  // One position half. A latitude starts a new position: whatever pair came before belongs to
  // another fix. kDropped: the half pairs with nothing (the fix has no position until a pair).
  protocol::GnssPositionPairer::Result add_position(const protocol::GnssPosition& half);
  void set_status(const protocol::GnssStatus& status);
  void set_velocity(const protocol::GnssVelocity& velocity);
  void set_dop(const protocol::GnssDop& dop);

  // The time frame at localizer time t closes the fix; every held part is cleared. False when the
  // fix had no status frame (incomplete, nothing in `out`). Without a position the fix is invalid
  // (no fix); without DOP its hdop stays unknown (GnssInput's default).
  bool close(double t, GnssInput& out);

  // 0x130 halves that formed no position, since start (GnssPositionPairer::dropped).
  std::uint32_t positions_dropped() const { return pairer_.dropped(); }

 private:
  GnssInput assemble(double t) const;

  protocol::GnssPositionPairer pairer_{};
  protocol::GnssStatus status_{};
  protocol::GnssVelocity velocity_{};
  protocol::GnssDop dop_{};
  bool have_position_ = false;  // the pairer holds this fix's latitude + longitude
  bool have_status_ = false;
  bool have_velocity_ = false;
  bool have_dop_ = false;
};

}  // namespace v2xloc::firmware
