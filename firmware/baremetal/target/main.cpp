// The semihosting target image: the whole Localizer (EMBEDDED profile) as Cortex-R52 code, fed a
// fixture's periods (firmware/fixture) from a host file. Per period it writes the output line the
// host reference writes (format_period) plus the period's retired instructions and cycles in the
// localizer's calls, read from the PMU, and the instructions by bucket (period_buckets.hpp: the
// calls by kind, the ego scan by the Localizer's stage marks); at the end the painted stack's
// high-water mark.
//   usage (QEMU semihosting arguments): v2xloc_target.elf FIXTURE OUTPUT
// Exit status: 0 after the fixture's kEnd, 2 on bad arguments or I/O, 3 on a malformed fixture;
// a CPU exception ends the run with status 1 (startup.S). The host I/O is semihosting_io.cpp's.
#include <cstdint>
#include <cstring>

#include "firmware/baremetal/target/pmu.hpp"
#include "firmware/baremetal/target/semihosting_io.hpp"
#include "firmware/fixture/fixture_player.hpp"
#include "firmware/fixture/period_buckets.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

namespace {

v2xloc::Localizer g_localizer;
v2xloc::fixture::FixturePlayer g_player;

// Sums the PMU counts over the localizer calls of one period, in total and by bucket
// (period_buckets.hpp: the calls by kind, the ego scan by its stage marks).
class PmuMeter final : public v2xloc::fixture::CallMeter, public v2xloc::fixture::BucketTracker {
 public:
  void begin(v2xloc::fixture::Tag call) override {
    call_begins(call);  // between calls: entered() counts nothing
    in_call_ = true;
    i0_ = last_ = v2xloc::target::pmu_instructions();
    c0_ = v2xloc::target::pmu_cycles();
  }
  void end() override {
    const std::uint32_t i1 = v2xloc::target::pmu_instructions();
    const std::uint32_t c1 = v2xloc::target::pmu_cycles();
    by_bucket[static_cast<std::size_t>(current())] += i1 - last_;
    instructions += i1 - i0_;  // one call stays far below 2^32
    cycles += c1 - c0_;
    in_call_ = false;
  }
  void clear() {
    instructions = cycles = 0;
    for (std::uint64_t& n : by_bucket) n = 0;
  }
  std::uint64_t instructions = 0, cycles = 0;
  std::uint64_t by_bucket[v2xloc::fixture::kBuckets] = {};

 private:
  void entered(v2xloc::fixture::Bucket from) override {
    if (!in_call_) return;
    const std::uint32_t now = v2xloc::target::pmu_instructions();
    by_bucket[static_cast<std::size_t>(from)] += now - last_;
    last_ = now;
  }
  bool in_call_ = false;
  std::uint32_t i0_ = 0, c0_ = 0, last_ = 0;
};

// The stack below main's frame is painted before the run; the lowest word changed since is the
// high-water mark. The region lies between the semihosting heap (half of RAM up) and the stack
// (top of RAM down), so painting it touches nothing live.
constexpr std::uint32_t kPaint = 0x5afe57acu;
constexpr std::uintptr_t kPaintBytes = 512 * 1024;
constexpr std::uintptr_t kPaintMargin = 256;  // below the painting frame itself

std::uintptr_t stack_pointer() {
  std::uintptr_t sp;
  asm volatile("mov %0, sp" : "=r"(sp));
  return sp;
}

__attribute__((noinline)) std::uintptr_t paint_stack() {
  const std::uintptr_t top = (stack_pointer() - kPaintMargin) & ~std::uintptr_t{7};
  for (auto* p = reinterpret_cast<volatile std::uint32_t*>(top - kPaintBytes);
       p < reinterpret_cast<volatile std::uint32_t*>(top); ++p) {
    *p = kPaint;
  }
  return top;
}

std::uintptr_t stack_high_water(std::uintptr_t painted_top, std::uintptr_t main_sp) {
  auto* p = reinterpret_cast<const volatile std::uint32_t*>(painted_top - kPaintBytes);
  while (p < reinterpret_cast<const volatile std::uint32_t*>(painted_top) && *p == kPaint) ++p;
  return main_sp - reinterpret_cast<std::uintptr_t>(p);
}

void put_u64(char* buf, std::uint64_t v) {
  char digits[21];
  int k = 20;
  digits[k] = '\0';
  do {
    digits[--k] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  std::strcat(buf, digits + k);
}

// " instr N cycles C stages NAME N ..." (every bucket, period_buckets.hpp's order) and the newline.
void put_counts(char* line, const PmuMeter& meter) {
  std::strcat(line, " instr ");
  put_u64(line, meter.instructions);
  std::strcat(line, " cycles ");
  put_u64(line, meter.cycles);
  std::strcat(line, " stages");
  for (std::size_t b = 0; b < v2xloc::fixture::kBuckets; ++b) {
    std::strcat(line, " ");
    std::strcat(line, v2xloc::fixture::bucket_name(static_cast<v2xloc::fixture::Bucket>(b)));
    std::strcat(line, " ");
    put_u64(line, meter.by_bucket[b]);
  }
  std::strcat(line, "\n");
}

}  // namespace

int main(int argc, char** argv) {
  namespace io = v2xloc::target;
  if (argc != 3) {
    io::print("usage: v2xloc_target.elf FIXTURE OUTPUT\n");
    return 2;
  }
  const std::uintptr_t main_sp = stack_pointer();
  const std::uintptr_t painted_top = paint_stack();
  if (!io::open_files(argv[1], argv[2])) return 2;
  if (!g_player.open(io::fixture_source())) {
    io::print("v2xloc target: not a fixture of this version\n");
    return 3;
  }
  v2xloc::target::pmu_start();
  PmuMeter meter;
  g_localizer.set_stage_probe(meter.probe());
  // The period line (< kLineHead) and the counts: 13 buckets of at most 13 + 20 + 2 characters.
  constexpr std::size_t kLineHead = 256;
  char line[kLineHead + 64 + v2xloc::fixture::kBuckets * 36];
  for (;;) {
    const v2xloc::fixture::Step step = g_player.step(g_localizer, meter);
    if (step == v2xloc::fixture::Step::kEnd) break;
    if (step == v2xloc::fixture::Step::kError) {
      std::strcpy(line, "v2xloc target: fixture error after period ");
      put_u64(line, g_player.period());
      io::print(line);
      io::print(": ");
      io::print(g_player.error());
      io::print("\n");
      return 3;
    }
    if (step != v2xloc::fixture::Step::kPeriod) continue;
    if (v2xloc::fixture::format_period(line, kLineHead, g_player.period() - 1, g_player.label(),
                                       g_player.output()) == 0) {
      return 3;
    }
    put_counts(line, meter);
    io::write_output(line);
    meter.clear();
  }
  std::strcpy(line, "# stack_high_water ");
  put_u64(line, stack_high_water(painted_top, main_sp));
  std::strcat(line, " painted ");
  put_u64(line, kPaintBytes);
  std::strcat(line, "\n");
  io::write_output(line);
  io::print(line + 2);
  return io::close_files() ? 0 : 2;
}
