// Surveyed backgrounds on the trust list: the `background` line round trip and its hostile forms
// (names that leave the folder, digests of the wrong length, lines for agents or unknown ids,
// duplicates) refused with their line; the background file checked against that line (size
// bounds, SHA-256, magic, version, sender id, cell, count, order), each refusal with its status.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "firmware/trust/background_file.hpp"
#include "firmware/trust/trust_list.hpp"
#include "trust_list_fixture.hpp"

namespace v2xloc::trust {
namespace {

using test::parse;
using test::text_of;

// A valid background file of unit `sender` with `n` ascending keys at 0.5 m.
std::vector<std::uint8_t> background_bytes(std::uint32_t sender, std::size_t n) {
  std::vector<std::uint32_t> keys(n);
  for (std::size_t i = 0; i < n; ++i) keys[i] = static_cast<std::uint32_t>(1000 + 7 * i);
  std::vector<std::uint8_t> out(background_file_bytes(n));
  EXPECT_EQ(format_background(sender, 500'000, keys, out), out.size());
  return out;
}

// Infrastructure unit 1, surveyed, with a background; agent 32.
TrustList list_with_background(const std::vector<std::uint8_t>& file) {
  TrustList l = test::infra_and_agent("background unit ");
  TrustedSigner& infra = l.signers[0];
  infra.surveyed = true;
  infra.survey.position_m = {9.5, 9.5, 5.0};
  infra.has_background = true;
  const std::string name = "background_infra_0.bin";
  name.copy(infra.background_file.data(), name.size());
  infra.background_sha256 = sha256(file);
  return l;
}

// The list's text with its background line replaced by `line` (appended when there is none).
std::string with_background_line(const std::string& line) {
  std::string text = text_of(list_with_background(background_bytes(1, 4)));
  const std::size_t at = text.find("background 1 ");
  return text.replace(at, text.find('\n', at) - at, line);
}

const std::string kDigest(64, 'a');

TEST(TrustListBackground, RoundTrip) {
  const std::vector<std::uint8_t> file = background_bytes(1, 4);
  const TrustList l = list_with_background(file);
  const std::string text = text_of(l);
  EXPECT_NE(text.find("background 1 background_infra_0.bin "), std::string::npos) << text;
  TrustList back;
  ASSERT_EQ(parse(text, back).status, TrustListStatus::kOk) << text;
  ASSERT_EQ(back.count, 2u);
  EXPECT_TRUE(back.signers[0].has_background);
  EXPECT_STREQ(back.signers[0].background_file.data(), "background_infra_0.bin");
  EXPECT_EQ(back.signers[0].background_sha256, sha256(file));
  EXPECT_FALSE(back.signers[1].has_background);
  EXPECT_EQ(back.background_count(), 1u);
}

TEST(TrustListBackground, HostileLinesAreRefusedWithTheirLine) {
  const std::string long_name(kMaxBackgroundNameChars + 1, 'b');
  const struct {
    std::string line;
    TrustListStatus want;
  } cases[] = {
      {"background 1 ../secret.bin " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 /etc/passwd " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 sub/dir.bin " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 .hidden " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 .. " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 " + long_name + " " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 a%20b " + kDigest, TrustListStatus::kBadBackgroundName},
      {"background 1 bg.bin " + kDigest.substr(1), TrustListStatus::kBadBackgroundDigest},
      {"background 1 bg.bin " + kDigest + "a", TrustListStatus::kBadBackgroundDigest},
      {"background 1 bg.bin " + kDigest.substr(1) + "g", TrustListStatus::kBadBackgroundDigest},
      {"background 32 bg.bin " + kDigest, TrustListStatus::kBackgroundWithoutSigner},  // an agent
      {"background 7 bg.bin " + kDigest, TrustListStatus::kBackgroundWithoutSigner},   // nobody
      {"background x bg.bin " + kDigest, TrustListStatus::kBadSenderId},
      {"background 1 bg.bin", TrustListStatus::kSyntax},
      {"background 1 bg.bin " + kDigest + " extra", TrustListStatus::kSyntax},
      {"background 1 bg bin " + kDigest, TrustListStatus::kSyntax},
  };
  for (const auto& c : cases) {
    const std::string text = with_background_line(c.line);
    TrustList out;
    const TrustListParseResult r = parse(text, out);
    EXPECT_EQ(r.status, c.want) << c.line;
    EXPECT_EQ(r.line, 7u) << c.line;  // three comment lines, header, signer 1, survey, then the background
    EXPECT_EQ(out.count, 0u) << "nothing is kept from a refused list";
  }
  // A second background for the same unit, and one above its signer.
  std::string twice = text_of(list_with_background(background_bytes(1, 4)));
  const std::size_t at = twice.find("background 1 ");
  twice += twice.substr(at, twice.find('\n', at) - at + 1);
  TrustList out;
  EXPECT_EQ(parse(twice, out).status, TrustListStatus::kDuplicateBackground);
  const std::string above = "v2xloc-trust-list 1\nbackground 1 bg.bin " + kDigest + "\n";
  const TrustListParseResult r = parse(above, out);
  EXPECT_EQ(r.status, TrustListStatus::kBackgroundWithoutSigner);
  EXPECT_EQ(r.line, 2u);
  // A background before the unit's survey: the unit would be checked in a frame nobody surveyed.
  std::string unsurveyed = text_of(list_with_background(background_bytes(1, 4)));
  const std::size_t survey = unsurveyed.find("survey 1 ");
  unsurveyed.erase(survey, unsurveyed.find('\n', survey) - survey + 1);
  EXPECT_EQ(parse(unsurveyed, out).status, TrustListStatus::kBackgroundWithoutSigner);
}

TEST(BackgroundFile, ValidFileIsCopiedIntoTheCallersStorage) {
  const std::vector<std::uint8_t> file = background_bytes(1, 5);
  const TrustList l = list_with_background(file);
  std::vector<std::uint32_t> cells(8, 0xDEADu);
  BackgroundInfo info;
  ASSERT_EQ(parse_background(file, l.signers[0], cells, info), BackgroundStatus::kOk);
  EXPECT_EQ(info.sender_id, 1u);
  EXPECT_DOUBLE_EQ(info.cell_m, 0.5);
  ASSERT_EQ(info.cells, 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(cells[i], 1000 + 7 * i);
  EXPECT_EQ(cells[5], 0xDEADu);  // nothing written past the count
}

// Each defect, with the digest on the list made to match the altered bytes (so the parser gets
// past the digest to the defect itself), has its own status.
TEST(BackgroundFile, HostileFilesAreRefused) {
  const std::vector<std::uint8_t> good = background_bytes(1, 5);
  std::vector<std::uint32_t> cells(8);
  const auto status_of = [&](const std::vector<std::uint8_t>& bytes) {
    const TrustList l = list_with_background(bytes);
    BackgroundInfo info;
    const BackgroundStatus s = parse_background(bytes, l.signers[0], cells, info);
    EXPECT_EQ(info.cells, 0u);
    return s;
  };
  const auto patched = [&](std::size_t at, std::uint32_t v) {
    std::vector<std::uint8_t> b = good;
    for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
    return b;
  };
  EXPECT_EQ(status_of(std::vector<std::uint8_t>(good.begin(), good.begin() + 10)), BackgroundStatus::kBadSize);
  EXPECT_EQ(status_of(std::vector<std::uint8_t>(good.begin(), good.end() - 1)), BackgroundStatus::kBadSize);
  EXPECT_EQ(status_of(std::vector<std::uint8_t>(good.begin(), good.end() - 4)), BackgroundStatus::kBadSize);  // n says 5
  EXPECT_EQ(status_of(std::vector<std::uint8_t>(kMaxBackgroundFileBytes + 4, 0)), BackgroundStatus::kTooLarge);
  EXPECT_EQ(status_of(patched(0, 0x58585858u)), BackgroundStatus::kBadMagic);
  EXPECT_EQ(status_of(patched(8, 2)), BackgroundStatus::kBadVersion);
  EXPECT_EQ(status_of(patched(12, 3)), BackgroundStatus::kWrongSender);
  EXPECT_EQ(status_of(patched(16, kBackgroundMinCellUm - 1)), BackgroundStatus::kBadCell);
  EXPECT_EQ(status_of(patched(16, kBackgroundMaxCellUm + 1)), BackgroundStatus::kBadCell);
  EXPECT_EQ(status_of(patched(20, 0)), BackgroundStatus::kBadCount);
  EXPECT_EQ(status_of(background_bytes(1, 9)), BackgroundStatus::kBadCount);  // 9 cells, storage for 8
  EXPECT_EQ(status_of(patched(kBackgroundHeaderBytes + 8, 1007)), BackgroundStatus::kNotAscending);  // = its predecessor
  EXPECT_EQ(status_of(patched(kBackgroundHeaderBytes + 8, 1)), BackgroundStatus::kNotAscending);
  // The bytes as the list vouches for them, and nothing else.
  const TrustList l = list_with_background(good);
  std::vector<std::uint8_t> flipped = good;
  flipped.back() ^= 1;
  BackgroundInfo info;
  EXPECT_EQ(parse_background(flipped, l.signers[0], cells, info), BackgroundStatus::kDigestMismatch);
  EXPECT_EQ(parse_background(good, l.signers[1], cells, info), BackgroundStatus::kNoBackground);  // the agent
  for (int s = 0; s <= static_cast<int>(BackgroundStatus::kNotAscending); ++s) {
    EXPECT_NE(std::string(to_string(static_cast<BackgroundStatus>(s))), "?");
  }
}

TEST(BackgroundFile, WriterRefusesWhatTheFormatCannotHold) {
  const std::vector<std::uint32_t> keys = {1, 2, 3};
  std::vector<std::uint8_t> out(background_file_bytes(3));
  EXPECT_EQ(format_background(1, 500'000, keys, out), out.size());
  EXPECT_EQ(format_background(1, 500'000, {}, out), 0u);
  EXPECT_EQ(format_background(1, kBackgroundMinCellUm - 1, keys, out), 0u);
  EXPECT_EQ(format_background(1, 500'000, keys, std::span<std::uint8_t>(out.data(), out.size() - 1)), 0u);
}

}  // namespace
}  // namespace v2xloc::trust
