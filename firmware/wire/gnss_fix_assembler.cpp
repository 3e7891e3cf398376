#include "firmware/wire/gnss_fix_assembler.hpp"

namespace v2xloc::firmware {

protocol::GnssPositionPairer::Result GnssFixAssembler::add_position(const protocol::GnssPosition& half) {
  const protocol::GnssPositionPairer::Result r = pairer_.push(half);
  have_position_ = r == protocol::GnssPositionPairer::Result::kPaired;
  return r;
}

void GnssFixAssembler::set_status(const protocol::GnssStatus& status) {
  status_ = status;
  have_status_ = true;
}

void GnssFixAssembler::set_velocity(const protocol::GnssVelocity& velocity) {
  velocity_ = velocity;
  have_velocity_ = true;
}

void GnssFixAssembler::set_dop(const protocol::GnssDop& dop) {
  dop_ = dop;
  have_dop_ = true;
}

bool GnssFixAssembler::close(double t, GnssInput& out) {
  pairer_.end_fix();  // a latitude still waiting for its longitude is dropped
  const bool complete = have_status_;
  if (complete) out = assemble(t);
  have_position_ = have_status_ = have_velocity_ = have_dop_ = false;
  return complete;
}

GnssInput GnssFixAssembler::assemble(double t) const {
  GnssInput g;
  g.t = t;
  const bool fixed = status_.fix_type == protocol::GnssFixType::kFix2D || status_.fix_type == protocol::GnssFixType::kFix3D;
  g.valid = fixed && have_position_;
  if (have_position_) {
    g.lat_deg = pairer_.lat_deg();
    g.lon_deg = pairer_.lon_deg();
  }
  g.alt_m = status_.alt_m;
  g.h_acc = status_.h_acc_m;
  g.v_acc = status_.v_acc_m;
  g.num_sats = status_.num_sats;
  if (have_dop_) g.hdop = dop_.hdop;
  if (have_velocity_ && velocity_.valid) {
    g.velocity_valid = true;
    g.vel_east = velocity_.vel_east_mps;
    g.vel_north = velocity_.vel_north_mps;
    g.speed_acc = velocity_.speed_acc_mps;
  }
  return g;
}

}  // namespace v2xloc::firmware
