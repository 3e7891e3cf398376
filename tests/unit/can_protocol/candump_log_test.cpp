#include "host_sim/canlog/candump_log.hpp"

#include <gtest/gtest.h>

#include <sstream>

#include "firmware/protocol/can_messages.hpp"

namespace v2xloc::sim {
namespace {

TEST(CandumpLog, FormatsLikeCandump) {
  CandumpRecord r;
  r.timestamp_us = 1700000000123456;
  r.frame.id = 0x123;
  r.frame.dlc = 4;
  r.frame.data[0] = 0xDE;
  r.frame.data[1] = 0xAD;
  r.frame.data[2] = 0xBE;
  r.frame.data[3] = 0xEF;
  EXPECT_EQ(format_candump_line(r), "(1700000000.123456) can0 123#DEADBEEF");
  r.frame.id = 0x1ABCDEF0u | hal::CanFrame::kExtendedFlag;
  r.frame.dlc = 0;
  EXPECT_EQ(format_candump_line(r), "(1700000000.123456) can0 1ABCDEF0#");
}

TEST(CandumpLog, WriteReadRoundTrip) {
  std::stringstream ss;
  CandumpWriter w(ss, "vcan1");
  for (int i = 0; i < 50; ++i) {
    w.write(1700000000.0 + 0.1 * i, protocol::pack(protocol::PosePosition{i * 1.5, -i * 0.25, {}, static_cast<std::uint8_t>(i % 16)}));
  }
  EXPECT_EQ(w.frames_written(), 50u);
  const CandumpLog log = read_candump(ss);
  EXPECT_TRUE(log.errors.empty());
  ASSERT_EQ(log.records.size(), 50u);
  for (int i = 0; i < 50; ++i) {
    const auto& r = log.records[static_cast<std::size_t>(i)];
    EXPECT_EQ(r.timestamp_us, 1700000000000000 + 100000LL * i);
    EXPECT_EQ(r.interface, "vcan1");
    protocol::PosePosition p;
    ASSERT_EQ(protocol::unpack(r.frame, p), protocol::DecodeStatus::kOk);
    EXPECT_NEAR(p.x_m, i * 1.5, 1e-3);
  }
}

TEST(CandumpLog, GarbageLinesReportedAndSkipped) {
  std::stringstream ss;
  ss << "(1700000000.000001) can0 123#11\n"
     << "garbage\n"
     << "\n"
     << "(1700000000.1) can0 123#11\n"           // time stamp needs 6 digits
     << "(1700000000.000002) can0 123#112\n"     // odd hex digits
     << "(1700000000.000003) can0 800#11\n"      // standard id above 0x7FF
     << "(1700000000.000004) can0 1234#11\n"     // 4-digit id
     << "(1700000000.000005) can0 123#112233445566778899\n"  // 9 bytes
     << "(1700000000.000006) can0 123##1112233\n"            // CAN FD
     << "(1700000000.000007) can0 123#R\n"                   // remote frame
     << "(1700000000.000008) can0 12G#11\n"
     << "(1700000000.000009) can0\n"
     << "(1700000000.000010) can0 7FF#0102030405060708\r\n"; // CRLF tolerated
  const CandumpLog log = read_candump(ss);
  ASSERT_EQ(log.records.size(), 2u);
  EXPECT_EQ(log.records[1].frame.id, 0x7FFu);
  EXPECT_EQ(log.records[1].frame.dlc, 8);
  ASSERT_EQ(log.errors.size(), 10u);
  EXPECT_EQ(log.errors[0].line_number, 2u);
  for (const auto& e : log.errors) EXPECT_FALSE(e.message.empty());
  EXPECT_FALSE(read_candump_file("/nonexistent/x.log").errors.empty());
}

}  // namespace
}  // namespace v2xloc::sim
