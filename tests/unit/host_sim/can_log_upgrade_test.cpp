// Recordings made before CAN layout 2 keep working: the reader converts their log as it reads it
// (manifest without can_log.layout_version), a layout-2 log is read as it is, an unknown layout is
// refused, and upgrade_can_log (v2xloc-sim upgrade-can) rewrites the log beside the original.
#include "firmware/protocol/can_messages.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/can_log_upgrade.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "recording_dir_test.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace v2xloc::sim {
namespace {

// Two layout-1 fixes: position (lat 48.1374123, lon 11.5755456; then 48.1374200, 11.5755500),
// status, time + DOP (week 2290, 1234.5 s; hdop 1.2, pdop 1.9), as the recorder wrote them then.
constexpr const char* kLegacyLog =
    "(1700000000.000000) can0 130#AB2FB11CC049E606\n"
    "(1700000000.000000) can0 131#9C5A220459A008F1\n"
    "(1700000000.000000) can0 132#44D61200F2080C13\n"
    "(1700000000.200000) can0 130#F82FB11CEC49E606\n"
    "(1700000000.200000) can0 131#855BD2047F90182B\n"
    "(1700000000.200000) can0 132#ACD61200F2080C13\n";

class CanLogLayout : public test::RecordingDirTest {
 protected:
  void SetUp() override {
    make_recording("can_upgrade");
    write("can.log", kLegacyLog);
    m_["files"]["can_log"] = "can.log";
    m_["can_log"] = {{"file", "can.log"}, {"frames", 6}};
  }

  std::string open_error() {
    write("manifest.json", m_.dump(2));
    std::string err;
    return reader_.open(dir_.string(), err) ? std::string() : err;
  }
  std::vector<CanLogFrame> frames() {
    std::vector<CanLogFrame> out;
    std::string err;
    EXPECT_TRUE(reader_.can_frames(out, err)) << err;
    return out;
  }

  RecordingReader reader_;
};

hal::CanFrame frame_of(const CanLogFrame& f) {
  hal::CanFrame c;
  c.id = f.id;
  c.dlc = f.dlc;
  std::memcpy(c.data, f.data, 8);
  return c;
}

TEST_F(CanLogLayout, LegacyLogIsConvertedAsItIsRead) {
  ASSERT_EQ(open_error(), "");
  EXPECT_EQ(reader_.can_layout_version(), 1);
  const std::vector<CanLogFrame> can = frames();
  ASSERT_EQ(can.size(), 10u);
  const std::uint32_t ids[5] = {0x130, 0x130, 0x131, 0x134, 0x132};
  for (std::size_t i = 0; i < can.size(); ++i) EXPECT_EQ(can[i].id, ids[i % 5]) << i;
  protocol::GnssPosition lat, lon;
  protocol::GnssTime time;
  protocol::GnssDop dop;
  ASSERT_EQ(protocol::unpack(frame_of(can[5]), lat), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(frame_of(can[6]), lon), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(frame_of(can[8]), dop), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(frame_of(can[9]), time), protocol::DecodeStatus::kOk);
  EXPECT_EQ(lat.deg, 481374200 * 1e-7);
  EXPECT_EQ(lon.deg, 115755500 * 1e-7);
  EXPECT_EQ(lon.counter, 3);
  EXPECT_EQ(time.week, 2290);
  EXPECT_EQ(time.time_of_week_s, 1234604 * 0.001);
  EXPECT_EQ(time.counter, 1);
  EXPECT_EQ(dop.hdop, 12 * 0.1);
  EXPECT_EQ(dop.pdop, 19 * 0.1);
  EXPECT_NEAR(can[9].t, 0.2, 1e-6);  // unix seconds as a double: 2.4e-7 s resolution
}

TEST_F(CanLogLayout, LayoutVersionIsReadAndChecked) {
  m_["can_log"]["layout_version"] = 2;  // the same bytes now claim to be layout 2: read as they are
  ASSERT_EQ(open_error(), "");
  EXPECT_EQ(reader_.can_layout_version(), 2);
  EXPECT_EQ(frames().size(), 6u);
  for (const Json& bad : {Json(3), Json(0), Json("2"), Json(1.5)}) {
    m_["can_log"]["layout_version"] = bad;
    EXPECT_NE(open_error().find("can_log.layout_version"), std::string::npos) << bad.dump();
  }
}

TEST_F(CanLogLayout, UpgradeWritesTheConvertedLogBesideTheOriginal) {
  ASSERT_EQ(open_error(), "");
  const std::vector<CanLogFrame> converted_on_read = frames();
  CanLogUpgrade result;
  std::string err;
  ASSERT_TRUE(upgrade_can_log(dir_.string(), result, err)) << err;
  EXPECT_FALSE(result.already_current);
  EXPECT_EQ(result.log_file, "can_layout2.log");
  EXPECT_EQ(result.frames, 10u);
  EXPECT_EQ(result.conversion.positions, 2u);
  EXPECT_EQ(result.conversion.times, 2u);
  EXPECT_EQ(read("can.log"), kLegacyLog) << "the original stays";
  const Json m = Json::parse(read("manifest.json"));
  EXPECT_EQ(m["files"]["can_log"], "can_layout2.log");
  EXPECT_EQ(m["can_log"]["layout_version"], 2);
  EXPECT_EQ(m["can_log"]["converted_from"], "can.log");
  EXPECT_EQ(m["can_log"]["frames"], 10);

  ASSERT_TRUE(reader_.open(dir_.string(), err)) << err;
  EXPECT_EQ(reader_.can_layout_version(), 2);
  const std::vector<CanLogFrame> upgraded = frames();
  ASSERT_EQ(upgraded.size(), converted_on_read.size());
  for (std::size_t i = 0; i < upgraded.size(); ++i) {
    EXPECT_EQ(upgraded[i].t, converted_on_read[i].t);
    EXPECT_EQ(upgraded[i].id, converted_on_read[i].id);
    EXPECT_EQ(std::memcmp(upgraded[i].data, converted_on_read[i].data, 8), 0) << i;
  }
  ASSERT_TRUE(upgrade_can_log(dir_.string(), result, err)) << err;
  EXPECT_TRUE(result.already_current);
  EXPECT_EQ(result.log_file, "can_layout2.log");
}

}  // namespace
}  // namespace v2xloc::sim
