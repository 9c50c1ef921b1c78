#include "daemon/team_key.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "daemon/lcm_bus.h"
#include "test/support/temp_dir.h"
#include "tsc/announce_t.hpp"

namespace tsc {
namespace {

auto Encode = [](const announce_t& a) { return LcmBus::Encode(a); };

announce_t Announce() {
  announce_t a{};
  a.robot = 2;
  a.memory_version = 9;
  a.status = "running";
  a.hmac_size = 0;
  return a;
}

TEST(TeamKey, SignedMessageVerifiesAndAnyChangeOrOtherKeyFails) {
  const TeamKey dut("correct horse battery staple");
  announce_t a = Announce();
  SignMessage(dut, a, Encode);
  EXPECT_EQ(a.hmac_size, 32);
  EXPECT_TRUE(VerifyMessage(dut, a, Encode));

  announce_t forged = a;
  forged.memory_version = 10;  // a replay claiming a newer version
  EXPECT_FALSE(VerifyMessage(dut, forged, Encode));
  EXPECT_FALSE(VerifyMessage(TeamKey("another key"), a, Encode));
  announce_t unsigned_msg = Announce();
  EXPECT_FALSE(VerifyMessage(dut, unsigned_msg, Encode));
  announce_t cut = a;
  cut.hmac.pop_back();
  cut.hmac_size = 31;
  EXPECT_FALSE(VerifyMessage(dut, cut, Encode));
}

TEST(TeamKey, FileReadableByOthersIsRefusedNamingIt) {
  testing_support::TempDir dir("team_key_test");
  const auto file = dir.path() / "team.key";
  std::ofstream(file) << "  s3cret\n";
  ::chmod(file.c_str(), 0644);
  try {
    TeamKey::Load(file);
    FAIL();
  } catch (const TeamKeyError& e) {
    EXPECT_NE(std::string(e.what()).find("team.key"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("0644"), std::string::npos) << e.what();
  }
  ::chmod(file.c_str(), 0600);
  const TeamKey loaded = TeamKey::Load(file);
  announce_t a = Announce();
  SignMessage(loaded, a, Encode);
  EXPECT_TRUE(VerifyMessage(TeamKey("s3cret"), a, Encode));  // whitespace is not the key
  EXPECT_THROW(TeamKey::Load(dir.path() / "absent.key"), TeamKeyError);
  std::ofstream(dir.path() / "empty.key") << "\n";
  ::chmod((dir.path() / "empty.key").c_str(), 0600);
  EXPECT_THROW(TeamKey::Load(dir.path() / "empty.key"), TeamKeyError);
}

}  // namespace
}  // namespace tsc
