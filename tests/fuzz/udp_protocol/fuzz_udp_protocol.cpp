// Each input is split into datagrams by a 2-byte length prefix and pushed into one reassembler,
// so the fuzzer can build multi-fragment states (duplicates, conflicts, eviction) too.
#include <cstddef>
#include <cstdint>
#include <memory>

#include "firmware/protocol/pointcloud_udp.hpp"

using v2xloc::protocol::StaticPointCloudReassembler;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static auto* reassembler = new StaticPointCloudReassembler<2, 1024, 16>();
  reassembler->reset();
  std::int64_t now = 0;
  while (size >= 2) {
    std::size_t len = static_cast<std::size_t>(data[0] | (data[1] << 8)) % 1500;
    data += 2;
    size -= 2;
    if (len > size) len = size;
    reassembler->push(std::span<const std::uint8_t>(data, len), now);
    now += 50'000'000;
    data += len;
    size -= len;
  }
  return 0;
}
