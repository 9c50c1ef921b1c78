// HTTP Basic and Digest authentication against the worked example of RFC 2617 and round trips.

#include "drivers/camera/http_auth.h"

#include <gtest/gtest.h>

namespace tsc {
namespace {

TEST(HttpAuth, Md5AndBase64MatchKnownValues) {
  EXPECT_EQ(Md5Hex(""), "d41d8cd98f00b204e9800998ecf8427e");
  EXPECT_EQ(Base64Encode("Aladdin:open sesame"), "QWxhZGRpbjpvcGVuIHNlc2FtZQ==");
  for (const std::string s : {"", "a", "ab", "abc", "root:p/+ss=word"}) {
    EXPECT_EQ(Base64Decode(Base64Encode(s)), s);
  }
  EXPECT_EQ(Base64Decode("not base64!"), std::nullopt);
}

TEST(HttpAuth, DigestResponseMatchesTheRfc2617Example) {
  // RFC 2617 §3.5.
  EXPECT_EQ(
      DigestResponse("Mufasa", "testrealm@host.com", "Circle Of Life", "GET", "/dir/index.html",
                     "dcd98b7102dd2f0e8b11d0f600bfb0c093", "00000001", "0a4f113b", "auth"),
      "6629fae49393a05397450978507c4ef1");
}

TEST(HttpAuth, ParsesChallengesAndCredentials) {
  const auto digest = ParseAuthHeader(
      R"(Digest realm="AXIS_00408C", nonce="abc,def", qop="auth", algorithm=MD5, stale=FALSE)");
  ASSERT_TRUE(digest);
  EXPECT_EQ(digest->scheme, "digest");
  EXPECT_EQ(digest->params.at("realm"), "AXIS_00408C");
  EXPECT_EQ(digest->params.at("nonce"), "abc,def");
  EXPECT_EQ(digest->params.at("algorithm"), "MD5");
  const auto basic = ParseAuthHeader("Basic cm9vdDpwLytzcz13b3Jk");
  ASSERT_TRUE(basic);
  EXPECT_EQ(basic->scheme, "basic");
  EXPECT_EQ(Base64Decode(basic->token68), "root:p/+ss=word");
  EXPECT_EQ(ParseAuthHeader(""), std::nullopt);
  EXPECT_EQ(ParseAuthHeader(R"(Digest realm="unterminated)"), std::nullopt);
}

TEST(HttpAuthenticator, AnswersADigestChallengeTheServerCanCheck) {
  HttpAuthenticator dut("root", "secret");
  EXPECT_EQ(dut.Authorization("GET", "/x"), "");
  ASSERT_TRUE(dut.Challenge(R"(Digest realm="r", nonce="n1", qop="auth", opaque="o")"));
  for (const std::string nc : {"00000001", "00000002"}) {
    const auto answer = ParseAuthHeader(dut.Authorization("GET", "/axis-cgi/com/ptz.cgi?pan=1"));
    ASSERT_TRUE(answer);
    const auto& p = answer->params;
    EXPECT_EQ(p.at("nc"), nc);
    EXPECT_EQ(p.at("opaque"), "o");
    EXPECT_EQ(p.at("response"),
              DigestResponse("root", "r", "secret", "GET", "/axis-cgi/com/ptz.cgi?pan=1", "n1",
                             p.at("nc"), p.at("cnonce"), "auth"));
  }
  ASSERT_TRUE(dut.Challenge(R"(Basic realm="r")"));
  EXPECT_EQ(dut.Authorization("GET", "/"), BasicAuthorization("root", "secret"));
  EXPECT_FALSE(dut.Challenge(R"(Digest realm="r", nonce="n", algorithm=SHA-256)"));
  EXPECT_NE(dut.error().find("SHA-256"), std::string::npos);
  EXPECT_FALSE(dut.Challenge("Negotiate abc"));
}

}  // namespace
}  // namespace tsc
