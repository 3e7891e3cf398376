// SHA-256 for the replayer's share signing: the x86 SHA extensions where the CPU has them (hashing
// every map-share payload through mbedTLS was a tenth of the replayer's instructions), otherwise
// the firmware's trust::sha256. Same digest either way (tests/unit/host_sim/host_sha256_test.cpp).
#pragma once

#include <cstdint>
#include <span>

#include "firmware/trust/p256.hpp"

namespace v2xloc::sim::replay {

trust::Digest host_sha256(std::span<const std::uint8_t> bytes);

// True when host_sha256() uses the SHA extensions on this CPU.
bool host_sha256_accelerated();

}  // namespace v2xloc::sim::replay
