// The static-state check's planted violations (check_static_state.py --self-test): one of each
// kind of mutable static storage it must report, and constants it must let pass. Never linked.
#include <cstdint>

namespace planted {

std::uint32_t g_counter = 7;       // namespace scope, initialized: .data
std::uint32_t g_table[64];         // namespace scope, zero: .bss
thread_local std::uint32_t g_per_thread = 1;  // thread-local: .tdata
namespace {
std::uint32_t g_hidden[16];        // internal linkage: .bss
}  // namespace

struct Holder {
  static inline std::uint32_t shared = 3;  // class static: .data
};

constexpr std::uint32_t kConstexprTable[4] = {1, 2, 3, 4};  // constants: .rodata, not reported
extern const std::uint32_t kConstTable[4];
const std::uint32_t kConstTable[4] = {5, 6, 7, 8};

std::uint32_t bump() {
  static std::uint32_t calls = 0;  // function-local static: .bss
  return ++calls;
}

std::uint32_t compute(std::uint32_t x) { return x * 2654435761u; }

std::uint32_t lazy(std::uint32_t x) {
  static const std::uint32_t value = compute(x);  // dynamic initialization: the value and its guard
  return value;
}

std::uint32_t use(std::uint32_t i) {
  static constexpr std::uint32_t kLocalConstant[2] = {9, 10};
  g_hidden[i % 16] += i;
  g_table[i % 64] += g_hidden[(i + 1) % 16];
  g_per_thread += i;
  Holder::shared += i;
  return g_counter++ + g_table[i % 64] + g_per_thread + bump() + lazy(i) + kConstexprTable[i % 4] +
         kConstTable[i % 4] + kLocalConstant[i % 2] + Holder::shared;
}

}  // namespace planted
