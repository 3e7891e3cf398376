// Scripted GPIO and HID backends: events released by the simulated clock, in order.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <string>

#include "hal/emulated/scripted_gpio_line.hpp"
#include "hal/emulated/scripted_hid_device.hpp"
#include "hal/emulated/sim_clock.hpp"
#include "hal/hid_imu_report.hpp"

namespace v2xloc::hal {
namespace {

std::string write_temp(const char* name, const char* text) {
  const std::string path = std::string(V2XLOC_BINARY_DIR) + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fputs(text, f);
  std::fclose(f);
  return path;
}

TEST(ScriptedGpio, PpsEdgesAreReleasedWhenTheClockReachesThem) {
  SimClock clock(0);
  ScriptedGpioLine pps(clock);
  const std::string path = write_temp("pps_script.txt",
                                      "# PPS: 100 ms pulses\n1000000000 rising\n1100000000 falling\n\n"
                                      "2000000000 rising  # second pulse\n2100000000 falling\n");
  ASSERT_EQ(pps.load_script(path.c_str()), Status::kOk);
  EXPECT_EQ(pps.pending_edges(), 4u);
  GpioEdge e;
  EXPECT_EQ(pps.read_edge(e), Status::kWouldBlock);
  clock.advance_to(1'050'000'000);
  ASSERT_EQ(pps.read_edge(e), Status::kOk);
  EXPECT_EQ(e.kind, GpioEdge::Kind::kRising);
  EXPECT_EQ(e.timestamp_ns, 1'000'000'000);  // the scripted (true) edge time, not the read time
  bool level = false;
  pps.get_value(level);
  EXPECT_TRUE(level);
  EXPECT_EQ(pps.read_edge(e), Status::kWouldBlock);
  clock.advance_to(5'000'000'000);
  int n = 0;
  std::int64_t last = 0;
  while (pps.read_edge(e) == Status::kOk) {
    EXPECT_GT(e.timestamp_ns, last);
    last = e.timestamp_ns;
    ++n;
  }
  EXPECT_EQ(n, 3);
  EXPECT_EQ(pps.set_value(true), Status::kUnsupported);
}

TEST(ScriptedGpio, BadScriptsAndOutOfOrderEdgesAreRejected) {
  SimClock clock(0);
  ScriptedGpioLine line(clock);
  EXPECT_EQ(line.load_script(write_temp("bad_gpio.txt", "100 sideways\n").c_str()), Status::kMalformed);
  ScriptedGpioLine ordered(clock);
  EXPECT_EQ(ordered.push_edge({GpioEdge::Kind::kRising, 100}), Status::kOk);
  EXPECT_EQ(ordered.push_edge({GpioEdge::Kind::kFalling, 99}), Status::kInvalidArgument);
  EXPECT_EQ(line.load_script("/nonexistent/v2xloc/script"), Status::kIoError);
}

TEST(ScriptedGpio, LedOutputChangesAreRecordedWithSimTime) {
  SimClock clock(0);
  ScriptedGpioLine led(clock, /*is_output=*/true);
  led.set_value(false);
  clock.advance_to(300);
  led.set_value(true);
  led.set_value(true);  // no change, not recorded
  clock.advance_to(700);
  led.set_value(false);
  ASSERT_EQ(led.output_history().size(), 3u);
  EXPECT_EQ(led.output_history()[1].timestamp_ns, 300);
  EXPECT_TRUE(led.output_history()[1].active);
  EXPECT_EQ(led.output_history()[2].timestamp_ns, 700);
  GpioEdge e;
  EXPECT_EQ(led.read_edge(e), Status::kUnsupported);
}

TEST(ScriptedHid, ImuReportsReplayInTimeOrder) {
  SimClock clock(0);
  ScriptedHidDevice imu(clock);
  std::array<std::uint8_t, hid_imu::kInputReportBytes> bytes{};
  for (int i = 0; i < 5; ++i) {
    hid_imu::RawReport r;
    r.counter = static_cast<std::uint8_t>(i);
    r.gyro[2] = static_cast<std::int16_t>(100 * i);
    hid_imu::encode_input_report(r, bytes);
    ASSERT_EQ(imu.push_report(10'000'000LL * i, bytes), Status::kOk);
  }
  std::array<std::uint8_t, 64> buf{};
  HidReportInfo info;
  clock.advance_to(25'000'000);
  int read = 0;
  while (imu.read_report(buf, info) == Status::kOk) {
    hid_imu::RawReport r;
    ASSERT_EQ(hid_imu::decode_input_report(std::span<const std::uint8_t>(buf.data(), info.size), r), Status::kOk);
    EXPECT_EQ(r.counter, read);
    EXPECT_EQ(r.gyro[2], 100 * read);
    EXPECT_EQ(info.timestamp_ns, 10'000'000LL * read);  // its scripted arrival, not the read time
    ++read;
  }
  EXPECT_EQ(read, 3);  // reports at 0, 10, 20 ms
  EXPECT_EQ(imu.pending_reports(), 2u);
  std::array<std::uint8_t, 4> small{};
  clock.advance_to(30'000'000);
  EXPECT_EQ(imu.read_report(small, info), Status::kBufferTooSmall);  // consumed, not half-delivered
  EXPECT_EQ(imu.pending_reports(), 1u);

  std::array<std::uint8_t, hid_imu::kOutputReportBytes> cmd{};
  hid_imu::encode_command(hid_imu::Command::kSetRate, 100, cmd);
  ASSERT_EQ(imu.write_report(cmd), Status::kOk);
  ASSERT_EQ(imu.written_reports().size(), 1u);
  EXPECT_EQ(imu.written_reports()[0].bytes[1], 1);
}

TEST(ScriptedHid, LoadsHexScripts) {
  SimClock clock(0);
  ScriptedHidDevice imu(clock);
  const std::string path = write_temp("hid_script.txt", "# t_ns bytes\n5 01 02 ff\n7 01 aa\n");
  ASSERT_EQ(imu.load_script(path.c_str()), Status::kOk);
  clock.advance_to(10);
  std::array<std::uint8_t, 64> buf{};
  HidReportInfo info;
  ASSERT_EQ(imu.read_report(buf, info), Status::kOk);
  EXPECT_EQ(info.size, 3u);
  EXPECT_EQ(buf[2], 0xFF);
  ASSERT_EQ(imu.read_report(buf, info), Status::kOk);
  EXPECT_EQ(buf[1], 0xAA);
  EXPECT_EQ(imu.load_script(write_temp("bad_hid.txt", "5 01 100\n").c_str()), Status::kMalformed);
}

}  // namespace
}  // namespace v2xloc::hal
