// v2xloc-fixture: the host side of the target runs (docs/target.md).
//   record RECORDING FIXTURE [--frames N] [--label NAME] [--outputs FILE]
//       runs the recording through the offline wire path (the firmware's decoder, share schedule
//       and trust checks; host_sim/replay/event_stream.hpp) and writes every input it applies to
//       the localizer as a fixture; --outputs: that run's period lines.
//   play FIXTURE OUTPUT [--callgrind]
//       plays the fixture into this build's Localizer and writes its period lines: the host
//       reference the target image's lines must equal, bit for bit. --callgrind: callgrind dumps
//       per period and bucket (tools/timing/fixture_instructions.py).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define V2XLOC_HAVE_CALLGRIND 1
#endif

#include "firmware/fixture/fixture_player.hpp"
#include "firmware/fixture/period_buckets.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/replay/event_stream.hpp"
#include "tools/target/fixture_writer.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

namespace {

v2xloc::Localizer g_localizer;
v2xloc::fixture::FixturePlayer g_player;

int usage() {
  std::fprintf(stderr,
               "usage: v2xloc-fixture record RECORDING FIXTURE [--frames N] [--label NAME] [--outputs FILE]\n"
               "       v2xloc-fixture play FIXTURE OUTPUT [--callgrind]\n");
  return 2;
}

bool put_line(std::FILE* f, std::uint32_t period, const char* label, const v2xloc::LocalizerFrameOutput& out) {
  char line[256];
  const std::size_t n = v2xloc::fixture::format_period(line, sizeof line, period, label, out);
  return n > 0 && std::fprintf(f, "%s\n", line) > 0;
}

int record(int argc, char** argv) {
  if (argc < 4) return usage();
  const std::string recording = argv[2], fixture = argv[3];
  std::string label = "run", outputs;
  int frames = -1;
  for (int i = 4; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--frames") == 0) frames = std::atoi(argv[i + 1]);
    else if (std::strcmp(argv[i], "--label") == 0) label = argv[i + 1];
    else if (std::strcmp(argv[i], "--outputs") == 0) outputs = argv[i + 1];
    else return usage();
  }
  using namespace v2xloc;
  sim::RecordingReader reader;
  std::string error;
  if (!reader.open(recording, error)) {
    std::fprintf(stderr, "v2xloc-fixture: %s\n", error.c_str());
    return 1;
  }
  fixture::FixtureWriter writer;
  if (!writer.open(fixture)) {
    std::fprintf(stderr, "v2xloc-fixture: cannot write %s\n", fixture.c_str());
    return 1;
  }
  std::FILE* lines = outputs.empty() ? nullptr : std::fopen(outputs.c_str(), "w");
  if (!outputs.empty() && lines == nullptr) return 1;
  // As the firmware (firmware/app/configure_localizer.hpp): the default parameters.
  writer.configure(reader.origin_lat_deg(), reader.origin_lon_deg(), reader.origin_alt_m());
  writer.label(label);
  g_localizer.configure(LocalizerParams{}, make_geodetic_origin(reader.origin_lat_deg(), reader.origin_lon_deg(),
                                                                reader.origin_alt_m()));
  auto decoder = std::make_unique<firmware::InputDecoder>();
  sim::replay::EventStreamConfig config;
  config.max_frames = frames;
  std::uint32_t period = 0;
  bool lines_ok = true;
  const bool ran = sim::replay::run_offline(
      reader, g_localizer, *decoder, config,
      [&](const sim::replay::DecodedFrame& f) {
        // A refused ego scan republishes the last pose without a localizer call: not a period here.
        if (period >= writer.periods()) return;
        if (lines != nullptr) lines_ok = put_line(lines, period, label.c_str(), f.output) && lines_ok;
        ++period;
      },
      error, &writer);
  if (lines != nullptr) lines_ok = std::fclose(lines) == 0 && lines_ok;
  if (!ran) {
    std::fprintf(stderr, "v2xloc-fixture: %s\n", error.c_str());
    return 1;
  }
  if (!writer.close() || !lines_ok) {
    std::fprintf(stderr, "v2xloc-fixture: write failed\n");
    return 1;
  }
  std::printf("v2xloc-fixture: %s: %llu periods, %llu clouds clipped to %zu points\n", fixture.c_str(),
              static_cast<unsigned long long>(writer.periods()), static_cast<unsigned long long>(writer.clouds_clipped()),
              fixture::kMaxPoints);
  return 0;
}

class FileSource final : public v2xloc::fixture::ByteSource {
 public:
  explicit FileSource(std::FILE* f) : f_(f) {}
  bool read(void* dst, std::size_t n) override { return std::fread(dst, 1, n, f_) == n; }

 private:
  std::FILE* f_;
};

// Under callgrind (--callgrind, valgrind --collect-atstart=no): instructions are collected only
// inside the localizer calls, as the target's PMU counts them, and dumped at every change of
// bucket (period_buckets.hpp) as "period P BUCKET", the target's split of the same work.
class CallgrindMeter final : public v2xloc::fixture::CallMeter, public v2xloc::fixture::BucketTracker {
 public:
  explicit CallgrindMeter(bool on) : on_(on) {}
  void begin(v2xloc::fixture::Tag call) override {
    call_begins(call);
    toggle();
  }
  void end() override { toggle(); }
  void period_done() {
    dump(current());
    reset();
    ++period_;
  }

 private:
  void entered(v2xloc::fixture::Bucket from) override { dump(from); }
  void dump(v2xloc::fixture::Bucket b) {
#ifdef V2XLOC_HAVE_CALLGRIND
    if (!on_ || b == v2xloc::fixture::Bucket::kCount) return;
    char label[64];
    std::snprintf(label, sizeof label, "period %u %s", period_, v2xloc::fixture::bucket_name(b));
    CALLGRIND_DUMP_STATS_AT(label);
#else
    (void)b;
#endif
  }
  void toggle() {
#ifdef V2XLOC_HAVE_CALLGRIND
    if (on_) CALLGRIND_TOGGLE_COLLECT;
#endif
  }
  bool on_;
  std::uint32_t period_ = 0;
};

int play(int argc, char** argv) {
  const bool callgrind = argc == 5 && std::strcmp(argv[4], "--callgrind") == 0;
  if (argc != 4 && !callgrind) return usage();
  std::FILE* in = std::fopen(argv[2], "rb");
  std::FILE* out = std::fopen(argv[3], "w");
  if (in == nullptr || out == nullptr) {
    std::fprintf(stderr, "v2xloc-fixture: cannot open %s or %s\n", argv[2], argv[3]);
    return 1;
  }
  FileSource source(in);
  if (!g_player.open(source)) {
    std::fprintf(stderr, "v2xloc-fixture: %s: %s\n", argv[2], g_player.error());
    return 1;
  }
  CallgrindMeter meter(callgrind);
  if (callgrind) g_localizer.set_stage_probe(meter.probe());
  for (;;) {
    const v2xloc::fixture::Step step = g_player.step(g_localizer, meter);
    if (step == v2xloc::fixture::Step::kPeriod) meter.period_done();
    if (step == v2xloc::fixture::Step::kEnd) break;
    if (step == v2xloc::fixture::Step::kError) {
      std::fprintf(stderr, "v2xloc-fixture: %s: %s\n", argv[2], g_player.error());
      return 1;
    }
    if (step == v2xloc::fixture::Step::kPeriod && !put_line(out, g_player.period() - 1, g_player.label(), g_player.output())) {
      return 1;
    }
  }
  std::fclose(in);
  return std::fclose(out) == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "record") == 0) return record(argc, argv);
  if (argc >= 2 && std::strcmp(argv[1], "play") == 0) return play(argc, argv);
  return usage();
}
