// The shared struct can_frame codec: byte layout, flags, rejection of bad frames.
#include "hal/socketcan_frame.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include <array>
#include <cstring>

namespace v2xloc::hal {
namespace {

TEST(SocketCanFrame, StandardFrameHasTheKernelLayout) {
  hal::CanFrame f;
  f.id = 0x123;
  f.dlc = 3;
  f.data[0] = 0xDE;
  f.data[1] = 0xAD;
  f.data[2] = 0xBE;
  std::array<std::uint8_t, kSocketCanFrameBytes> bytes{};
  ASSERT_EQ(encode_socketcan_frame(f, bytes), Status::kOk);
  struct can_frame cf;
  std::memcpy(&cf, bytes.data(), sizeof cf);
  EXPECT_EQ(cf.can_id, 0x123u);
  EXPECT_EQ(cf.len, 3u);
  EXPECT_EQ(cf.data[0], 0xDE);
  EXPECT_EQ(cf.data[2], 0xBE);
  EXPECT_EQ(cf.data[3], 0);  // unused bytes are zero, so datagrams are deterministic
  EXPECT_EQ(bytes[8], 0xDE);  // data starts at offset 8 (struct can_frame is 8-byte aligned)
  CanRxFrame rx;
  ASSERT_EQ(decode_socketcan_frame(bytes, rx), Status::kOk);
  EXPECT_EQ(rx.frame.id, f.id);
  EXPECT_EQ(rx.frame.dlc, f.dlc);
  EXPECT_EQ(std::memcmp(rx.frame.data, f.data, 8), 0);
  EXPECT_FALSE(rx.error);
  EXPECT_FALSE(rx.remote);
}

TEST(SocketCanFrame, ExtendedFrameSetsEffFlag) {
  hal::CanFrame f;
  f.id = 0x1ABCDEF0u | hal::CanFrame::kExtendedFlag;
  f.dlc = 8;
  for (int i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(0xF0 + i);
  std::array<std::uint8_t, kSocketCanFrameBytes> bytes{};
  ASSERT_EQ(encode_socketcan_frame(f, bytes), Status::kOk);
  EXPECT_EQ(socketcan_raw_id(bytes), 0x1ABCDEF0u | CAN_EFF_FLAG);
  CanRxFrame rx;
  ASSERT_EQ(decode_socketcan_frame(bytes, rx), Status::kOk);
  EXPECT_EQ(rx.frame.id, f.id);
  EXPECT_EQ(std::memcmp(rx.frame.data, f.data, 8), 0);
}

TEST(SocketCanFrame, InvalidFramesAreRejected) {
  std::array<std::uint8_t, kSocketCanFrameBytes> bytes{};
  hal::CanFrame f;
  f.dlc = 9;
  EXPECT_EQ(encode_socketcan_frame(f, bytes), Status::kInvalidArgument);
  f.dlc = 1;
  f.id = 0x800;  // not an 11-bit id and no extended flag
  EXPECT_EQ(encode_socketcan_frame(f, bytes), Status::kInvalidArgument);
  CanRxFrame rx;
  EXPECT_EQ(decode_socketcan_frame(std::span<const std::uint8_t>(bytes.data(), 15), rx), Status::kMalformed);
  std::array<std::uint8_t, CANFD_MTU> fd{};
  EXPECT_EQ(decode_socketcan_frame(fd, rx), Status::kMalformed);  // CAN FD frames are not classic frames
  bytes[4] = 9;                                                   // len > 8
  EXPECT_EQ(decode_socketcan_frame(bytes, rx), Status::kMalformed);
}

TEST(SocketCanFrame, ErrorAndRemoteFramesAreFlagged) {
  struct can_frame cf;
  std::memset(&cf, 0, sizeof cf);
  cf.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF | CAN_ERR_CRTL;
  cf.len = CAN_ERR_DLC;
  cf.data[1] = CAN_ERR_CRTL_RX_PASSIVE;
  std::array<std::uint8_t, kSocketCanFrameBytes> bytes{};
  std::memcpy(bytes.data(), &cf, sizeof cf);
  CanRxFrame rx;
  ASSERT_EQ(decode_socketcan_frame(bytes, rx), Status::kOk);
  EXPECT_TRUE(rx.error);
  EXPECT_EQ(rx.error_class, can_error::kBusOff | can_error::kController);
  EXPECT_EQ(rx.frame.data[1], CAN_ERR_CRTL_RX_PASSIVE);

  cf.can_id = 0x321 | CAN_RTR_FLAG;
  cf.len = 0;
  std::memcpy(bytes.data(), &cf, sizeof cf);
  ASSERT_EQ(decode_socketcan_frame(bytes, rx), Status::kOk);
  EXPECT_FALSE(rx.error);
  EXPECT_TRUE(rx.remote);
  EXPECT_EQ(rx.frame.id, 0x321u);
}

TEST(SocketCanFrame, ErrorClassConstantsMatchTheKernel) {
  EXPECT_EQ(can_error::kTxTimeout, CAN_ERR_TX_TIMEOUT);
  EXPECT_EQ(can_error::kLostArbitration, CAN_ERR_LOSTARB);
  EXPECT_EQ(can_error::kController, CAN_ERR_CRTL);
  EXPECT_EQ(can_error::kProtocol, CAN_ERR_PROT);
  EXPECT_EQ(can_error::kTransceiver, CAN_ERR_TRX);
  EXPECT_EQ(can_error::kNoAck, CAN_ERR_ACK);
  EXPECT_EQ(can_error::kBusOff, CAN_ERR_BUSOFF);
  EXPECT_EQ(can_error::kBusError, CAN_ERR_BUSERROR);
  EXPECT_EQ(can_error::kRestarted, CAN_ERR_RESTARTED);
}

TEST(SocketCanFrame, FilterMatchingFollowsCanRawSemantics) {
  const CanFilter exact{0x120, CanFilter::kStandardMask};
  EXPECT_TRUE(can_filter_matches(exact, 0x120));
  EXPECT_FALSE(can_filter_matches(exact, 0x121));
  EXPECT_FALSE(can_filter_matches(exact, 0x120 | CAN_EFF_FLAG));  // format must match too
  const CanFilter range{0x100, 0x700};                             // 0x100..0x1FF, any format
  EXPECT_TRUE(can_filter_matches(range, 0x1FF));
  EXPECT_FALSE(can_filter_matches(range, 0x200));
}

}  // namespace
}  // namespace v2xloc::hal
