// Our candump logs and CAN frames, checked by third-party tools: python-can, can-utils' log2asc
// and the npm DBC library candied. Host-only; skipped with a reason where a tool is missing.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <unistd.h>

#include "dbc_reader.hpp"
#include "host_sim/canlog/candump_log.hpp"
#include "message_bindings.hpp"

namespace v2xloc::test {
namespace {

namespace fs = std::filesystem;

fs::path work_dir() {
  // Per process: ctest -j runs these tests concurrently, each in its own process.
  const fs::path d = fs::path(V2XLOC_BINARY_DIR) / "test_work" / ("can_protocol_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

int run(const std::string& cmd, std::string* output = nullptr) {
  const fs::path out = work_dir() / "cmd_output.txt";
  const int rc = std::system((cmd + " > " + out.string() + " 2>&1").c_str());
  if (output) {
    std::ifstream in(out);
    std::stringstream ss;
    ss << in.rdbuf();
    *output = ss.str();
  }
  return rc;
}

// A log with every message type, random values.
std::vector<sim::CandumpRecord> write_log(const fs::path& path) {
  const Dbc dbc = read_dbc(std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc");
  std::mt19937_64 rng(7);
  std::ofstream out(path);
  sim::CandumpWriter w(out);
  std::vector<sim::CandumpRecord> written;
  int k = 0;
  for (int round = 0; round < 20; ++round) {
    for (const auto& b : message_bindings()) {
      Values v;
      for (const auto& [name, s] : dbc.messages.at(b.id).signals) {
        std::uniform_real_distribution<double> u(s.min, s.max);
        v[name] = s.factor == 1.0 ? std::round(u(rng)) : u(rng);
      }
      sim::CandumpRecord r;
      r.timestamp_us = 1700000000000000 + 1000LL * k++;
      r.frame = b.pack(v, nullptr);
      w.write(r.timestamp_us, r.frame);
      written.push_back(r);
    }
  }
  return written;
}

TEST(ThirdPartyTools, PythonCanReadsEveryFrame) {
  if (run("/usr/bin/python3 -c 'import can'") != 0) GTEST_SKIP() << "python3-can not installed";
  const fs::path log = work_dir() / "all_messages.log";
  const auto written = write_log(log);
  const fs::path script = work_dir() / "read_log.py";
  std::ofstream(script) << "import can, sys\n"
                           "for m in can.CanutilsLogReader(sys.argv[1]):\n"
                           "    print('%d %.6f %d %s' % (m.arbitration_id, m.timestamp, m.dlc, m.data.hex()))\n";
  std::string output;
  ASSERT_EQ(run("/usr/bin/python3 " + script.string() + " " + log.string(), &output), 0) << output;
  std::istringstream lines(output);
  std::size_t i = 0;
  std::string line;
  while (std::getline(lines, line)) {
    ASSERT_LT(i, written.size());
    unsigned id = 0, dlc = 0;
    double ts = 0.0;
    char hex[32] = {};
    ASSERT_EQ(std::sscanf(line.c_str(), "%u %lf %u %31s", &id, &ts, &dlc, hex), 4) << line;
    const auto& r = written[i++];
    EXPECT_EQ(id, r.frame.id);
    EXPECT_EQ(dlc, r.frame.dlc);
    EXPECT_NEAR(ts, static_cast<double>(r.timestamp_us) * 1e-6, 2e-6);
    char expect[32] = {};
    for (int b = 0; b < r.frame.dlc; ++b) std::snprintf(expect + 2 * b, 3, "%02x", r.frame.data[b]);
    EXPECT_STREQ(hex, expect);
  }
  EXPECT_EQ(i, written.size());
}

TEST(ThirdPartyTools, Log2ascConvertsTheLog) {
  if (run("command -v log2asc") != 0) GTEST_SKIP() << "can-utils (log2asc) not installed";
  const fs::path log = work_dir() / "all_messages_asc.log";
  const auto written = write_log(log);
  const fs::path asc = work_dir() / "all_messages.asc";
  std::string output;
  ASSERT_EQ(run("log2asc -I " + log.string() + " -O " + asc.string() + " can0", &output), 0) << output;
  std::ifstream in(asc);
  std::string line;
  std::size_t frames = 0;
  while (std::getline(in, line)) {
    // Frame lines: "<time> <channel> <id> Rx d <dlc> <bytes...>"
    std::istringstream ls(line);
    double t;
    int channel;
    std::string id, dir, d;
    if (ls >> t >> channel >> id >> dir >> d && dir == "Rx" && d == "d") {
      ASSERT_LT(frames, written.size());
      EXPECT_EQ(std::stoul(id, nullptr, 16), written[frames].frame.id) << line;
      ++frames;
    }
  }
  EXPECT_EQ(frames, written.size());
}

TEST(ThirdPartyTools, CandiedDecodesOurFramesWithTheDbc) {
  if (run("command -v node && command -v npm") != 0) GTEST_SKIP() << "node/npm not installed";
  const fs::path pkg = fs::path(V2XLOC_BINARY_DIR) / "candied";
  if (!fs::exists(pkg / "node_modules" / "candied" / "package.json")) {
    fs::create_directories(pkg);
    std::string output;
    if (run("cd " + pkg.string() + " && timeout 180 npm install --no-audit --no-fund --prefix . candied@2.2.0", &output) != 0 ||
        !fs::exists(pkg / "node_modules" / "candied" / "package.json")) {
      GTEST_SKIP() << "npm could not install candied@2.2.0: " << output.substr(0, 300);
    }
  }
  // Frames with the physical values our own decoder reads from them.
  const fs::path frames = work_dir() / "frames.txt";
  {
    const Dbc dbc = read_dbc(std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc");
    std::mt19937_64 rng(11);
    std::ofstream out(frames);
    out.precision(12);
    for (int round = 0; round < 50; ++round) {
      for (const auto& b : message_bindings()) {
        Values v;
        for (const auto& [name, s] : dbc.messages.at(b.id).signals) {
          std::uniform_real_distribution<double> u(s.min, s.max);
          v[name] = s.factor == 1.0 ? std::round(u(rng)) : u(rng);
        }
        const auto f = b.pack(v, nullptr);
        Values decoded;
        ASSERT_EQ(b.unpack(f, decoded), protocol::DecodeStatus::kOk);
        out << f.id;
        for (int i = 0; i < 8; ++i) out << ' ' << static_cast<int>(f.data[i]);
        for (const auto& [name, value] : decoded) out << ' ' << name << '=' << value;
        out << '\n';
      }
    }
  }
  const fs::path script = work_dir() / "candied_check.js";
  std::ofstream(script)
      << "const { Dbc, Can } = require('candied');\n"
         "const fs = require('fs');\n"
         "const can = new Can(); can.database = new Dbc().load(fs.readFileSync(process.argv[2], 'utf8'));\n"
         "let bad = 0, checked = 0;\n"
         "for (const line of fs.readFileSync(process.argv[3], 'utf8').split('\\n')) {\n"
         "  if (!line) continue;\n"
         "  const p = line.split(' ');\n"
         "  const id = Number(p[0]); const bytes = p.slice(1, 9).map(Number);\n"
         "  const msg = can.decode(can.createFrame(id, bytes));\n"
         "  if (!msg) { console.log('no message for id', id); bad++; continue; }\n"
         "  for (const kv of p.slice(9)) {\n"
         "    const [name, value] = kv.split('=');\n"
         "    const sig = msg.boundSignals.get(name);\n"
         "    if (!sig) { console.log('missing', msg.name, name); bad++; continue; }\n"
         "    checked++;\n"
         "    if (Math.abs(sig.value - Number(value)) > 1e-6 * Math.max(1, Math.abs(Number(value)))) {\n"
         "      console.log('mismatch', msg.name, name, sig.value, value); bad++; }\n"
         "  }\n"
         "}\n"
         "console.log('checked', checked, 'bad', bad);\n"
         "process.exit(bad === 0 && checked > 0 ? 0 : 1);\n";
  std::string output;
  const int rc = run("NODE_PATH=" + (pkg / "node_modules").string() + " node " + script.string() + " " +
                         std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc " + frames.string(),
                     &output);
  EXPECT_EQ(rc, 0) << output;
  EXPECT_NE(output.find("bad 0"), std::string::npos) << output;
}

}  // namespace
}  // namespace v2xloc::test
