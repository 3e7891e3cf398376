// Surveyed infrastructure poses on the trust list: the `survey` line round trip, hostile fields
// refused with their line, older lists (no survey) unchanged, and the verifier refusing an
// infrastructure share that declares a pose off its survey (the rogue-shift attack, signed).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "firmware/trust/map_share_verifier.hpp"
#include "firmware/trust/trust_list.hpp"
#include "trust_list_fixture.hpp"

namespace v2xloc::trust {
namespace {

using test::parse;
using test::text_of;

// Infrastructure unit 1 (surveyed at (9.5, 9.5, 5), yawed 135 deg), agent 32.
TrustList surveyed_list() {
  TrustList l = test::infra_and_agent("survey unit ");
  TrustedSigner& infra = l.signers[0];
  infra.surveyed = true;
  const double half = 0.5 * 135.0 * M_PI / 180.0;
  infra.survey.position_m = {9.5, 9.5, 5.0};
  infra.survey.quaternion_xyzw = {0.0, 0.0, std::sin(half), std::cos(half)};
  return l;
}

// The list's text with the survey line replaced by `line`.
std::string with_survey(const std::string& line) {
  std::string text = text_of(surveyed_list());
  const std::size_t at = text.find("survey 1 ");
  const std::size_t end = text.find('\n', at);
  return text.replace(at, end - at, line);
}

TEST(TrustListSurvey, RoundTripIsBitExact) {
  const TrustList l = surveyed_list();
  const std::string text = text_of(l);
  TrustList back;
  ASSERT_EQ(parse(text, back).status, TrustListStatus::kOk) << text;
  ASSERT_EQ(back.count, 2u);
  EXPECT_TRUE(back.signers[0].surveyed);
  EXPECT_FALSE(back.signers[1].surveyed);
  EXPECT_EQ(back.surveyed_count(), 1u);
  EXPECT_EQ(std::memcmp(&back.signers[0].survey, &l.signers[0].survey, sizeof(SurveyedPose)), 0);
  EXPECT_EQ(text_of(back), text);
}

TEST(TrustListSurvey, ListWithoutSurveyStillParses) {
  TrustList l = surveyed_list();
  l.signers[0].surveyed = false;
  const std::string text = text_of(l);
  EXPECT_EQ(text.find("\nsurvey"), std::string::npos);
  // As written before surveys existed: the old comment header, signer lines only.
  const std::string old = "# v2xloc trust list: signer <role> <sender id> <P-256 public key 04||X||Y hex> [name]\n" +
                          text.substr(text.find("v2xloc-trust-list 1"));
  TrustList back;
  ASSERT_EQ(parse(old, back).status, TrustListStatus::kOk);
  EXPECT_EQ(back.count, 2u);
  EXPECT_EQ(back.surveyed_count(), 0u);
}

TEST(TrustListSurvey, HostileSurveysAreRefusedWithTheirLine) {
  const std::string good = with_survey("survey 1 1 2 3 0 0 0 1");
  TrustList ok;
  ASSERT_EQ(parse(good, ok).status, TrustListStatus::kOk);
  const std::size_t line = 6;  // three comment lines, header, signer 1, then the survey
  struct Case {
    std::string survey;
    TrustListStatus status;
  };
  const Case cases[] = {
      {"survey 1 nan 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1 inf 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1 2 -infinity 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1e999 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},     // overflows to inf
      {"survey 1 1e6 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},       // beyond 100 km
      {"survey 1 0x10 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},      // hex
      {"survey 1 1. 2 3 0 0 0 1", TrustListStatus::kOk},                     // "1." is a decimal
      {"survey 1 . 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1e 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1,5 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 " + std::string(41, '1') + " 2 3 0 0 0 1", TrustListStatus::kBadSurveyNumber},
      {"survey 1 1 2 3 0 0 0 nan", TrustListStatus::kBadSurveyQuaternion},
      {"survey 1 1 2 3 0 0 0 0", TrustListStatus::kBadSurveyQuaternion},     // zero
      {"survey 1 1 2 3 0 0 0 1.001", TrustListStatus::kBadSurveyQuaternion}, // not unit
      {"survey 1 1 2 3 0 0 1 1", TrustListStatus::kBadSurveyQuaternion},
      {"survey 1 1 2 3 0 0 0 1e300", TrustListStatus::kBadSurveyQuaternion},
      {"survey 1 1 2 3 0 0 0", TrustListStatus::kSyntax},                    // a field missing
      {"survey 1 1 2 3 0 0 0 1 9", TrustListStatus::kSyntax},
      {"survey 32 1 2 3 0 0 0 1", TrustListStatus::kSurveyWithoutSigner},    // an agent
      {"survey 7 1 2 3 0 0 0 1", TrustListStatus::kSurveyWithoutSigner},     // nobody
      {"survey x 1 2 3 0 0 0 1", TrustListStatus::kBadSenderId},
  };
  for (const Case& c : cases) {
    TrustList out;
    const TrustListParseResult r = parse(with_survey(c.survey), out);
    EXPECT_EQ(r.status, c.status) << c.survey << ": " << to_string(r.status);
    if (c.status != TrustListStatus::kOk) {
      EXPECT_EQ(r.line, line) << c.survey;
      EXPECT_EQ(out.count, 0u) << c.survey;
      EXPECT_GT(std::strlen(to_string(r.status)), 10u);
    }
  }
  TrustList out;
  const TrustListParseResult twice = parse(good + "survey 1 1 2 3 0 0 0 1\n", out);
  EXPECT_EQ(twice.status, TrustListStatus::kDuplicateSurvey);
  // A survey before its signer is listed names nobody yet.
  const std::string text = text_of(surveyed_list());
  const std::size_t s = text.find("survey 1 "), e = text.find('\n', s) + 1;
  std::string moved = text;
  const std::string survey_line = moved.substr(s, e - s);
  moved.erase(s, e - s);
  moved.insert(moved.find("\nsigner") + 1, survey_line);
  EXPECT_EQ(parse(moved, out).status, TrustListStatus::kSurveyWithoutSigner);
}

protocol::SensorPose declared(const SurveyedPose& p) {
  protocol::SensorPose d;
  for (int i = 0; i < 3; ++i) d.position_m[i] = p.position_m[static_cast<std::size_t>(i)];
  for (int i = 0; i < 4; ++i) d.quaternion_xyzw[i] = p.quaternion_xyzw[static_cast<std::size_t>(i)];
  return d;
}

TEST(TrustListSurvey, DeclaredPoseMustMatchTheSurvey) {
  const SurveyedPose survey = surveyed_list().signers[0].survey;
  const MapShareVerifierConfig config;
  protocol::SensorPose d = declared(survey);
  EXPECT_TRUE(matches_survey(survey, d, config));
  for (int i = 0; i < 4; ++i) d.quaternion_xyzw[i] = -d.quaternion_xyzw[i];  // -q: the same rotation
  EXPECT_TRUE(matches_survey(survey, d, config));
  for (int i = 0; i < 4; ++i) d.quaternion_xyzw[i] *= -2.0;  // not normalized on the wire
  EXPECT_TRUE(matches_survey(survey, d, config));
  for (const double shift : {0.25, 3.0, 200.0, 0.021, -0.021}) {
    d = declared(survey);
    d.position_m[0] += shift;
    EXPECT_FALSE(matches_survey(survey, d, config)) << shift;
  }
  d = declared(survey);
  d.position_m[1] += 0.019;
  EXPECT_TRUE(matches_survey(survey, d, config));
  // Yaw off by 0.06 deg / 0.04 deg (tolerance 0.05 deg).
  for (const double deg : {0.06, 0.04}) {
    const double half = 0.5 * (135.0 + deg) * M_PI / 180.0;
    d = declared(survey);
    d.quaternion_xyzw[2] = std::sin(half);
    d.quaternion_xyzw[3] = std::cos(half);
    EXPECT_EQ(matches_survey(survey, d, config), deg < 0.05) << deg;
  }
  d = declared(survey);
  d.position_m[2] = std::nan("");
  EXPECT_FALSE(matches_survey(survey, d, config));
  d = declared(survey);
  for (double& q : d.quaternion_xyzw) q = 0.0;
  EXPECT_FALSE(matches_survey(survey, d, config));
  d = declared(survey);
  d.quaternion_xyzw[0] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(matches_survey(survey, d, config));
}

}  // namespace
}  // namespace v2xloc::trust
