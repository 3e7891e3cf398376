// SHA-256 for the replayer's share signing: OpenSSL's (SHA extensions where the CPU has them), the
// same digest as the firmware's trust::sha256 (tests/unit/host_sim/openssl_sha256_test.cpp), so a
// share signed here verifies in the firmware.
#pragma once

#include <cstdint>
#include <span>

#include "firmware/trust/p256.hpp"

namespace v2xloc::sim::replay {

trust::Digest openssl_sha256(std::span<const std::uint8_t> bytes);

}  // namespace v2xloc::sim::replay
