// The wire format pinned byte for byte: representative and edge values of all 17 messages packed,
// raw bit patterns a faulty sender could put on the bus decoded, and corrupted frames refused, each
// rendered as one line and compared with the checked-in golden_frames.txt. A codec change that
// alters one bit, one saturation count, one decoded value or one status fails here.
// V2XLOC_WRITE_CAN_GOLDEN=1 rewrites the file from the codec under test (a deliberate layout change
// only; the test then reports itself skipped).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dbc_reader.hpp"
#include "message_bindings.hpp"

namespace v2xloc::test {
namespace {

std::string golden_path() { return std::string(V2XLOC_SOURCE_DIR) + "/tests/unit/can_protocol/golden_frames.txt"; }

// Physical inputs by DBC signal name; a name left out is 0.
struct EncodeCase {
  const char* message;
  const char* inputs;
};

// In range, range ends, rounding halves, out of range both ways, NaN and infinities in every
// double field, integer fields beyond their signal, counters beyond 15, angles to wrap and the
// diagnostic frames' clamped flags (set by saturation or by the caller).
constexpr EncodeCase kEncodeCases[] = {
    {"VehicleMotion", "WheelSpeed=12.34 YawRate=-0.4321 SpeedValid=1 YawRateValid=1 Counter=7"},
    {"VehicleMotion", "WheelSpeed=-327.68 YawRate=3.2767 SpeedValid=0 YawRateValid=1 Counter=15"},
    {"VehicleMotion", "WheelSpeed=500 YawRate=-10 SpeedValid=1 YawRateValid=0 Counter=16"},
    {"VehicleMotion", "WheelSpeed=nan YawRate=inf Counter=255"},
    {"VehicleMotion", "WheelSpeed=0.005 YawRate=-0.00005 Counter=1"},
    {"VehicleMotion", "WheelSpeed=-0.015 YawRate=-inf Counter=2"},
    {"GnssPosition", "PositionMux=0 Latitude=48.1371549 Counter=6"},
    {"GnssPosition", "PositionMux=1 Longitude=-179.9999999 Counter=7"},
    {"GnssPosition", "PositionMux=0 Latitude=95 Counter=0"},
    {"GnssPosition", "PositionMux=1 Longitude=-200 Counter=15"},
    {"GnssPosition", "PositionMux=0 Latitude=nan Counter=1"},
    {"GnssPosition", "PositionMux=1 Longitude=11.5755 Counter=31"},
    {"GnssPosition", "PositionMux=0 Latitude=-90 Counter=2"},
    {"GnssStatus", "Altitude=519.37 HorizontalAccuracy=4.75 VerticalAccuracy=8.2 NumSatellites=11 FixType=2 Counter=15"},
    {"GnssStatus", "Altitude=20000 HorizontalAccuracy=-1 VerticalAccuracy=nan NumSatellites=99 FixType=3 Counter=0"},
    {"GnssStatus", "Altitude=-1000 HorizontalAccuracy=204.75 VerticalAccuracy=0 NumSatellites=63 FixType=0 Counter=9"},
    {"GnssStatus", "Altitude=-1500 HorizontalAccuracy=inf VerticalAccuracy=300 NumSatellites=0 FixType=7 Counter=200"},
    {"GnssTime", "TimeOfWeek=345600.125 Week=2390 Counter=12"},
    {"GnssTime", "TimeOfWeek=604799.999 Week=65535 Counter=15"},
    {"GnssTime", "TimeOfWeek=700000 Week=0 Counter=3"},
    {"GnssTime", "TimeOfWeek=-1 Week=1 Counter=4"},
    {"GnssTime", "TimeOfWeek=nan Week=2400 Counter=5"},
    {"GnssTime", "TimeOfWeek=0.0005 Week=2 Counter=6"},
    {"GnssVelocity", "VelEast=3.21 VelNorth=-7.65 VelUp=0.12 SpeedAccuracy=0.08 VelocityValid=1 Counter=4"},
    {"GnssVelocity", "VelEast=400 VelNorth=-400 VelUp=20 SpeedAccuracy=9 VelocityValid=0 Counter=15"},
    {"GnssVelocity", "VelEast=-327.68 VelNorth=327.67 VelUp=-10.24 SpeedAccuracy=5.1 VelocityValid=1 Counter=0"},
    {"GnssVelocity", "VelEast=nan VelNorth=inf VelUp=-inf SpeedAccuracy=-1 Counter=17"},
    {"GnssDop", "Hdop=1.3 Pdop=2.1 Counter=5"},
    {"GnssDop", "Hdop=99 Pdop=inf Counter=0"},
    {"GnssDop", "Hdop=0 Pdop=25.5 Counter=15"},
    {"GnssDop", "Hdop=-3 Pdop=nan Counter=8"},
    {"PosePosition", "PoseX=-123.4567 PoseY=4567.891 PoseValid=1 GnssUsed=1 Counter=3"},
    {"PosePosition", "PoseX=9000 PoseY=-9000 RegistrationValid=1 Degraded=1 Counter=15"},
    {"PosePosition", "PoseX=8388.607 PoseY=-8388.608 PoseValid=1 RegistrationValid=1 GnssUsed=1 Degraded=1 Counter=0"},
    {"PosePosition", "PoseX=nan PoseY=0.0005 Counter=22"},
    {"PoseAttitude", "PoseZ=1.23 PoseYaw=-2.5 FrameCounter=65535 RegistrationValid=1 Degraded=1 Counter=9"},
    {"PoseAttitude", "PoseZ=400 PoseYaw=9.42477796076938 FrameCounter=0 PoseValid=1 Counter=15"},
    {"PoseAttitude", "PoseZ=-400 PoseYaw=-7 FrameCounter=1234 GnssUsed=1 Counter=1"},
    {"PoseAttitude", "PoseZ=nan PoseYaw=nan FrameCounter=7 Counter=2"},
    {"PoseAttitude", "PoseZ=0 PoseYaw=inf FrameCounter=8 Counter=3"},
    {"PoseAttitude", "PoseZ=0.005 PoseYaw=3.14159265358979 Counter=4"},
    {"PoseSigma", "SigmaX=0.012 SigmaY=0.034 SigmaZ=0.5 SigmaYaw=0.01 Counter=1"},
    {"PoseSigma", "SigmaX=25 SigmaY=-0.1 SigmaZ=nan SigmaYaw=1 Counter=15"},
    {"PoseSigma", "SigmaX=20.475 SigmaY=0 SigmaZ=inf SigmaYaw=0.4095 Counter=16"},
    {"RegistrationPosition", "RegX=12.345 RegY=-67.891 RegAttempted=1 RegOk=1 Counter=5"},
    {"RegistrationPosition", "RegX=1e6 RegY=0 RegAttempted=1 Counter=6"},
    {"RegistrationPosition", "RegX=1 RegY=2 RegClamped=1 Counter=7"},
    {"RegistrationPosition", "RegX=nan RegY=-8388.608 RegAttempted=1 Counter=15"},
    {"RegistrationQuality", "RegZ=0.5 RegFitness=0.9 RegRmse=0.05 FrameCounter=17 Counter=1"},
    {"RegistrationQuality", "RegZ=40 RegFitness=2 RegRmse=5 FrameCounter=65535 Counter=15"},
    {"RegistrationQuality", "RegZ=-32.768 RegFitness=1.023 RegRmse=0 FrameCounter=0 Counter=0"},
    {"RegistrationQuality", "RegZ=nan RegFitness=-1 RegRmse=inf FrameCounter=3 Counter=20"},
    {"GateDecision", "DecidedFrame=10 FrameCounter=14 GateDecided=1 GateValid=1 Mode=2 FilterInitialized=1 Counter=1"},
    {"GateDecision", "DecidedFrame=65535 FrameCounter=0 GateDecided=1 Mode=3 Counter=15"},
    {"GateDecision", "DecidedFrame=0 FrameCounter=65535 GateValid=1 Mode=1 Counter=16"},
    {"GateDecision", "Mode=255 Counter=2"},
    {"OdometryPosition", "OdomX=3 OdomY=4 OdometryOk=1 Counter=1"},
    {"OdometryPosition", "OdomX=-9000 OdomY=5 OdometryOk=1 Counter=2"},
    {"OdometryPosition", "OdomX=1 OdomY=1 OdomClamped=1 Counter=15"},
    {"OdometryPosition", "OdomX=nan OdomY=inf Counter=0"},
    {"OdometryAttitude", "OdomZ=-1.9 OdomYaw=0.5 FrameCounter=17 OdometryOk=1 Counter=1"},
    {"OdometryAttitude", "OdomZ=50 OdomYaw=-4 FrameCounter=65535 Counter=2"},
    {"OdometryAttitude", "OdomZ=0 OdomYaw=nan FrameCounter=0 OdomClamped=1 Counter=3"},
    {"OdometryAttitude", "OdomZ=-32.768 OdomYaw=12.5 FrameCounter=1 OdometryOk=1 Counter=15"},
    {"Heartbeat", "State=3 ErrorFlags=5 Uptime=3600.4 CanRxErrors=17 UdpDropped=200 Counter=12"},
    {"Heartbeat", "State=9 ErrorFlags=255 Uptime=2e6 CanRxErrors=255 UdpDropped=0 Counter=15"},
    {"Heartbeat", "State=0 ErrorFlags=0 Uptime=nan CanRxErrors=0 UdpDropped=255 Counter=0"},
    {"Heartbeat", "State=5 ErrorFlags=15 Uptime=-5 Counter=33"},
    {"TrustRejections", "UnknownSigner=1 BadSignature=2 TooOld=3 Future=4 Replay=5 QueueOverflow=6 PoseMismatch=7 Counter=8"},
    {"TrustRejections",
     "UnknownSigner=255 BadSignature=0 TooOld=255 Future=0 Replay=255 QueueOverflow=0 PoseMismatch=200 Counter=15"},
    {"TrustRejections", "PoseMismatch=15 Counter=16"},
    {"InputGuards",
     "CanCrcRejected=1 CanCounterRejected=22 EgoTimeRejected=333 MissingSignature=4095 BackgroundMismatch=5 Counter=6"},
    {"InputGuards",
     "CanCrcRejected=65535 CanCounterRejected=4096 EgoTimeRejected=0 MissingSignature=5000 BackgroundMismatch=99 Counter=15"},
    {"InputGuards", "BackgroundMismatch=15 Counter=0"},
};

Values parse_inputs(const std::string& text) {
  Values v;
  std::istringstream in(text);
  std::string item;
  while (in >> item) {
    const auto eq = item.find('=');
    v[item.substr(0, eq)] = std::strtod(item.c_str() + eq + 1, nullptr);
  }
  return v;
}

std::string frame_text(const hal::CanFrame& f) {
  char buf[64];
  int n = std::snprintf(buf, sizeof buf, "%03X#", static_cast<unsigned>(f.id));
  for (int i = 0; i < 8; ++i) n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), "%02X", f.data[i]);
  std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " dlc=%u", static_cast<unsigned>(f.dlc));
  return buf;
}

// The status, and for a decoded frame (ok or out of range) every value by name, exact to the bit.
std::string decoded_text(const MessageBinding& b, const hal::CanFrame& f) {
  Values v;
  const protocol::DecodeStatus s = b.unpack(f, v);
  std::string out = protocol::to_string(s);
  if (s != protocol::DecodeStatus::kOk && s != protocol::DecodeStatus::kOutOfRange) return out;
  for (const auto& [name, value] : v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " %s=%.17g", name.c_str(), value);
    out += buf;
  }
  return out;
}

struct Subject {
  const DbcMessage* dbc;
  MessageBinding binding;
};

// In identifier order (the DBC's).
std::vector<Subject> subjects(const Dbc& dbc) {
  std::vector<Subject> out;
  for (const auto& [id, m] : dbc.messages) {
    for (const MessageBinding& b : message_bindings())
      if (b.id == id) out.push_back({&m, b});
  }
  EXPECT_EQ(out.size(), dbc.messages.size());
  return out;
}

const Subject& by_name(const std::vector<Subject>& all, const std::string& name) {
  for (const Subject& s : all)
    if (s.dbc->name == name) return s;
  ADD_FAILURE() << "no message " << name;
  return all.front();
}

void render_encode_cases(const std::vector<Subject>& all, std::vector<std::string>& lines) {
  for (const EncodeCase& c : kEncodeCases) {
    const Subject& s = by_name(all, c.message);
    protocol::PackStats stats;
    const hal::CanFrame f = s.binding.pack(parse_inputs(c.inputs), &stats);
    lines.push_back(std::string("encode ") + c.message + " " + c.inputs + " | " + frame_text(f) +
                    " saturated=" + std::to_string(stats.saturated) + " | " + decoded_text(s.binding, f));
  }
}

// A zero payload with the multiplexer at `mux`, one signal set to `raw`, sealed with a valid CRC.
hal::CanFrame raw_frame(const DbcMessage& m, int mux, const DbcSignal* sig, std::uint64_t raw) {
  hal::CanFrame f;
  f.id = m.id;
  f.dlc = 8;
  if (const DbcSignal* mx = m.multiplexer(); mx != nullptr && mux >= 0)
    protocol::put_bits_le(f.data, mx->start, mx->length, static_cast<std::uint64_t>(mux));
  if (sig != nullptr) protocol::put_bits_le(f.data, sig->start, sig->length, raw);
  f.data[7] = protocol::frame_crc(f.id, f.data);
  return f;
}

// Per signal: all ones, the top bit alone (the most negative value of a signed signal) and, for a
// signed signal, the most positive value.
void render_raw_patterns(const std::vector<Subject>& all, std::vector<std::string>& lines) {
  for (const Subject& s : all) {
    for (const int mux : s.dbc->mux_values()) {
      const std::string head = "raw " + s.dbc->name + " mux=" + std::to_string(mux) + " ";
      const hal::CanFrame zero = raw_frame(*s.dbc, mux, nullptr, 0);
      lines.push_back(head + "zero | " + frame_text(zero) + " | " + decoded_text(s.binding, zero));
      for (const auto& [name, sig] : s.dbc->active(mux)) {
        if (name == "Crc") continue;
        const std::uint64_t ones = (std::uint64_t{1} << sig.length) - 1u;
        const std::uint64_t top = std::uint64_t{1} << (sig.length - 1u);
        for (const std::uint64_t raw : {ones, top, ones >> 1u}) {
          if ((raw == top && sig.length == 1) || (raw == ones >> 1u && !sig.is_signed)) continue;
          const hal::CanFrame f = raw_frame(*s.dbc, mux, &sig, raw);
          lines.push_back(head + name + "=" + std::to_string(raw) + " | " + frame_text(f) + " | " +
                          decoded_text(s.binding, f));
        }
      }
    }
  }
}

// Each message's first encode case, corrupted: DLC, CRC byte, a payload bit, the id.
void render_rejections(const std::vector<Subject>& all, std::vector<std::string>& lines) {
  for (std::size_t k = 0; k < all.size(); ++k) {
    const Subject& s = all[k];
    const char* inputs = "";
    for (const EncodeCase& c : kEncodeCases)
      if (s.dbc->name == c.message) {
        inputs = c.inputs;
        break;
      }
    const hal::CanFrame good = s.binding.pack(parse_inputs(inputs), nullptr);
    hal::CanFrame dlc7 = good, dlc0 = good, crc = good, bit = good, id = good;
    dlc7.dlc = 7;
    dlc0.dlc = 0;
    crc.data[7] ^= 0x01u;
    bit.data[3] ^= 0x10u;
    id.id = all[(k + 1) % all.size()].dbc->id;
    const std::pair<const char*, const hal::CanFrame*> cases[] = {
        {"dlc7", &dlc7}, {"dlc0", &dlc0}, {"crc", &crc}, {"payload_bit", &bit}, {"other_id", &id}};
    for (const auto& [what, f] : cases)
      lines.push_back("reject " + s.dbc->name + " " + what + " | " + frame_text(*f) + " | " + decoded_text(s.binding, *f));
  }
}

std::vector<std::string> render_golden() {
  const Dbc dbc = read_dbc(std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc");
  const std::vector<Subject> all = subjects(dbc);
  std::vector<std::string> lines;
  render_encode_cases(all, lines);
  render_raw_patterns(all, lines);
  render_rejections(all, lines);
  return lines;
}

TEST(CanGoldenFrames, CodecReproducesTheGoldenFile) {
  const std::vector<std::string> lines = render_golden();
  if (std::getenv("V2XLOC_WRITE_CAN_GOLDEN") != nullptr) {
    std::ofstream out(golden_path());
    for (const std::string& l : lines) out << l << '\n';
    ASSERT_TRUE(out.good()) << golden_path();
    GTEST_SKIP() << "wrote " << lines.size() << " lines to " << golden_path();
  }
  std::ifstream in(golden_path());
  ASSERT_TRUE(in) << golden_path();
  std::vector<std::string> golden;
  for (std::string l; std::getline(in, l);) golden.push_back(l);
  ASSERT_EQ(lines.size(), golden.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i] == golden[i]) continue;
    if (++differ <= 10) ADD_FAILURE() << "line " << i + 1 << "\n  golden: " << golden[i] << "\n  codec:  " << lines[i];
  }
  EXPECT_EQ(differ, 0u);
}

TEST(CanGoldenFrames, EveryMessageHasEncodeCases) {
  const Dbc dbc = read_dbc(std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc");
  ASSERT_EQ(dbc.messages.size(), 17u);
  for (const auto& [id, m] : dbc.messages) {
    int cases = 0;
    for (const EncodeCase& c : kEncodeCases) cases += m.name == c.message ? 1 : 0;
    EXPECT_GE(cases, 3) << m.name;
  }
}

}  // namespace
}  // namespace v2xloc::test
