// Real kernel backends. They run where the kernel offers AF_CAN + vcan0, a gpio-sim chip or
// /dev/uhid, and skip with the precise reason elsewhere (this build machine has none of them).
#include <fcntl.h>
#include <glob.h>
#include <gtest/gtest.h>
#include <linux/uhid.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <string>

#include "hal/hid_imu_report.hpp"
#include "hal/linux/gpiod_line.hpp"
#include "hal/linux/hidapi_device.hpp"
#include "hal/linux/socketcan_bus.hpp"

namespace v2xloc::hal {
namespace {

std::int64_t mono_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

TEST(SocketCanReal, Vcan0RoundTripWithKernelTimestampsAndFilters) {
  SocketCanBus tx, rx;
  if (tx.open(SocketCanOptions{"vcan0"}) != Status::kOk) {
    GTEST_SKIP() << tx.last_error() << " (needs AF_CAN and a vcan0: modprobe vcan; ip link add vcan0 type vcan; "
                                       "ip link set up vcan0)";
  }
  ASSERT_EQ(rx.open(SocketCanOptions{"vcan0"}), Status::kOk) << rx.last_error();
  const CanFilter only{0x123, CanFilter::kStandardMask};
  ASSERT_EQ(rx.set_filters(std::span<const CanFilter>(&only, 1)), Status::kOk) << rx.last_error();
  ASSERT_EQ(rx.set_error_mask(can_error::kAll), Status::kOk);
  hal::CanFrame skip, want;
  skip.id = 0x124;
  skip.dlc = 1;
  want.id = 0x123;
  want.dlc = 8;
  for (int i = 0; i < 8; ++i) want.data[i] = static_cast<std::uint8_t>(0xA0 + i);
  const std::int64_t before = mono_now();
  ASSERT_EQ(tx.send(skip), Status::kOk) << tx.last_error();
  ASSERT_EQ(tx.send(want), Status::kOk) << tx.last_error();
  CanRxFrame got;
  Status s;
  const std::int64_t give_up = mono_now() + 2'000'000'000;
  while ((s = rx.receive(got)) == Status::kWouldBlock && mono_now() < give_up) {
  }
  ASSERT_EQ(s, Status::kOk) << rx.last_error();
  EXPECT_EQ(got.frame.id, 0x123u);
  EXPECT_EQ(std::memcmp(got.frame.data, want.data, 8), 0);
  EXPECT_TRUE(rx.kernel_timestamps());
  EXPECT_GE(got.timestamp_ns, before - 1'000'000);
  EXPECT_LE(got.timestamp_ns, mono_now() + 1'000'000);
  EXPECT_EQ(rx.receive(got), Status::kWouldBlock);  // 0x124 was filtered by the kernel
}

TEST(SocketCanReal, BringUpNeedsARealInterfaceAndPrivileges) {
  SocketCanBus bus;
  SocketCanOptions o{"can0"};
  o.bring_up = true;
  const Status s = bus.open(o);
  if (s != Status::kOk) GTEST_SKIP() << "libsocketcan bring-up of can0: " << bus.last_error();
  EXPECT_TRUE(bus.is_open());
}

// gpio-sim exposes sim_gpioN/{pull,value} next to its gpiochip in sysfs: pulls drive inputs,
// values show outputs, so both directions can be checked without hardware.
std::string find_gpio_sim_chip(std::string& reason) {
  if (access("/sys/bus/gpio", F_OK) != 0) {
    reason = std::string("no GPIO subsystem: access(/sys/bus/gpio) failed: ") + std::strerror(errno);
    return {};
  }
  glob_t g{};
  const int rc = glob("/sys/bus/gpio/devices/gpiochip*/sim_gpio1", 0, nullptr, &g);
  std::string chip;
  if (rc == 0 && g.gl_pathc > 0) {
    const std::string path = g.gl_pathv[0];
    const auto start = path.find("gpiochip");
    chip = path.substr(start, path.find('/', start) - start);
  } else {
    reason = "no gpio-sim chip with >= 2 lines (modprobe gpio-sim; create a bank under "
             "/sys/kernel/config/gpio-sim and set live=1)";
  }
  globfree(&g);
  return chip;
}

TEST(GpiodReal, GpioSimPpsEdgesAndLedOutput) {
  std::string reason;
  const std::string chip = find_gpio_sim_chip(reason);
  if (chip.empty()) GTEST_SKIP() << reason;
  const std::string sysfs = "/sys/bus/gpio/devices/" + chip;
  GpiodLine led, pps;
  GpiodLineOptions out{chip.c_str(), 0, GpiodLineOptions::Mode::kOutput};
  ASSERT_EQ(led.open(out), Status::kOk) << led.last_error();
  ASSERT_EQ(led.set_value(true), Status::kOk);
  std::ifstream value(sysfs + "/sim_gpio0/value");
  int v = -1;
  value >> v;
  EXPECT_EQ(v, 1);
  ASSERT_EQ(pps.open(GpiodLineOptions{chip.c_str(), 1, GpiodLineOptions::Mode::kEdgeInput}), Status::kOk)
      << pps.last_error();
  GpioEdge e;
  EXPECT_EQ(pps.read_edge(e), Status::kWouldBlock);
  const std::int64_t before = mono_now();
  std::ofstream(sysfs + "/sim_gpio1/pull") << "pull-up";
  Status s;
  const std::int64_t give_up = mono_now() + 2'000'000'000;
  while ((s = pps.read_edge(e)) == Status::kWouldBlock && mono_now() < give_up) {
  }
  ASSERT_EQ(s, Status::kOk) << pps.last_error();
  EXPECT_EQ(e.kind, GpioEdge::Kind::kRising);
  EXPECT_GE(e.timestamp_ns, before - 1'000'000);  // CLOCK_MONOTONIC stamps (Linux >= 5.7)
}

TEST(GpiodReal, MissingChipGivesAReason) {
  GpiodLine line;
  const Status s = line.open(GpiodLineOptions{"gpiochip-does-not-exist", 0});
  EXPECT_NE(s, Status::kOk);
  EXPECT_NE(std::string(line.last_error()).find("gpiod_chip_open(gpiochip-does-not-exist) failed"), std::string::npos)
      << line.last_error();
}

// uhid: create a virtual HID IMU in the kernel, then talk to it through hidapi/hidraw.
TEST(HidapiReal, UhidImuReportsThroughHidraw) {
  const int fd = open("/dev/uhid", O_RDWR | O_CLOEXEC);
  if (fd < 0) GTEST_SKIP() << "open(/dev/uhid) failed: " << std::strerror(errno) << " (modprobe uhid; needs root)";
  uhid_event create{};
  create.type = UHID_CREATE2;
  std::snprintf(reinterpret_cast<char*>(create.u.create2.name), sizeof create.u.create2.name, "v2xloc test IMU");
  create.u.create2.rd_size = static_cast<__u16>(hid_imu::kReportDescriptor.size());
  create.u.create2.bus = BUS_USB;
  create.u.create2.vendor = hid_imu::kVendorId;
  create.u.create2.product = hid_imu::kProductId;
  std::memcpy(create.u.create2.rd_data, hid_imu::kReportDescriptor.data(), hid_imu::kReportDescriptor.size());
  ASSERT_EQ(write(fd, &create, sizeof create), static_cast<ssize_t>(sizeof create)) << std::strerror(errno);

  HidapiDevice dev;
  Status opened = Status::kIoError;
  const std::int64_t give_up = mono_now() + 3'000'000'000;
  while ((opened = dev.open(HidapiOptions{})) != Status::kOk && mono_now() < give_up) usleep(20'000);
  if (opened != Status::kOk) {
    close(fd);
    GTEST_SKIP() << "uhid device created but no hidraw node appeared: " << dev.last_error();
  }
  hid_imu::RawReport r;
  r.counter = 9;
  r.gyro[2] = -321;
  uhid_event input{};
  input.type = UHID_INPUT2;
  input.u.input2.size = static_cast<__u16>(hid_imu::encode_input_report(r, std::span<std::uint8_t>(input.u.input2.data, 64)));
  ASSERT_EQ(write(fd, &input, sizeof input), static_cast<ssize_t>(sizeof input));
  std::array<std::uint8_t, 64> buf{};
  HidReportInfo info;
  ASSERT_EQ(dev.read_report_timeout(buf, info, 2000), Status::kOk) << dev.last_error();
  hid_imu::RawReport back;
  ASSERT_EQ(hid_imu::decode_input_report(std::span<const std::uint8_t>(buf.data(), info.size), back), Status::kOk);
  EXPECT_EQ(back.counter, 9);
  EXPECT_EQ(back.gyro[2], -321);
  uhid_event destroy{};
  destroy.type = UHID_DESTROY;
  (void)!write(fd, &destroy, sizeof destroy);
  close(fd);
}

TEST(HidapiReal, MissingDeviceGivesAReason) {
  HidapiDevice dev;
  HidapiOptions o;
  o.path = "/dev/hidraw-does-not-exist";
  EXPECT_NE(dev.open(o), Status::kOk);
  EXPECT_NE(std::string(dev.last_error()).find("hid_open_path(/dev/hidraw-does-not-exist) failed"), std::string::npos)
      << dev.last_error();
}

}  // namespace
}  // namespace v2xloc::hal
