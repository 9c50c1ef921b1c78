#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include "core/memory/view_basis.h"
#include "settings/settings.h"
#include "test/support/temp_dir.h"

namespace tsc {
namespace {
namespace fs = std::filesystem;

class ConfigTest : public ::testing::Test {
 protected:
  fs::path Write(const std::string& text) {
    const fs::path p = dir_ / "test.ini";
    std::ofstream(p) << text;
    return p;
  }
  /// The ConfigError message of loading `text`, or "" when it loads.
  std::string ErrorOf(const std::string& text, const std::vector<std::string>& overrides = {}) {
    try {
      LoadSettings(Write(text), overrides);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  testing_support::TempDir temp_{"tscd_config_test"};
  fs::path dir_ = temp_.path();
};

TEST_F(ConfigTest, DefaultsValidate) {
  const Settings dut = LoadSettings(std::nullopt, {});
  EXPECT_NO_THROW(dut.pipeline.Validate());
  // Every key's default lies in its own range: re-applying it is accepted.
  Settings copy;
  for (const ConfigKey& k : ConfigTable()) {
    EXPECT_NO_THROW(k.set(copy, k.get(Settings{}))) << k.key;
  }
}

TEST_F(ConfigTest, TableKeysAreUniqueAndDocumented) {
  std::set<std::string> keys;
  for (const ConfigKey& k : ConfigTable()) {
    EXPECT_TRUE(keys.insert(k.key).second) << k.key;
    EXPECT_NE(k.key.find('.'), std::string::npos) << k.key;
    EXPECT_FALSE(k.description.empty()) << k.key;
    EXPECT_FALSE(k.RangeText().empty()) << k.key;
  }
  for (const char* required : {"robot.id",
                               "bubble.features",
                               "bubble.d_phi_deg",
                               "bubble.rest_radius",
                               "bubble.max_depth_m",
                               "bubble.patch_px",
                               "bubble.orientation_blur_deg",
                               "descriptor.harmonics_pan",
                               "descriptor.harmonics_tilt",
                               "descriptor.amplitude",
                               "detection.tau_mu",
                               "detection.tau_sigma",
                               "detection.tau_kappa",
                               "detection.tau_n",
                               "detection.tau_w",
                               "detection.tau_p",
                               "memory.tau_r",
                               "memory.tau_l",
                               "memory.tau_h",
                               "memory.max_samples_per_place",
                               "memory.max_vote_points",
                               "memory.svm_nu",
                               "memory.svm_gamma",
                               "memory.svm_max_training",
                               "pipeline.recognize_partial"}) {
    EXPECT_TRUE(keys.count(required)) << required;
  }
}

TEST_F(ConfigTest, FileSetsValues) {
  const fs::path file = Write(
      "# comment\n[robot]\nid = 7\n[bubble]\nfeatures = L1+I\nd_phi_deg = 5\n"
      "[detection]\ntau_kappa = 0.5\ntau_p = 2\n[memory]\ntau_r = 0.75\n"
      "[pipeline]\nrecognize_partial = false\n");
  const Settings dut = LoadSettings(file, {});
  EXPECT_EQ(dut.pipeline.robot, 7u);
  EXPECT_EQ(dut.pipeline.features.ToString(), FeatureSet::Parse("L1+I").ToString());
  EXPECT_DOUBLE_EQ(dut.pipeline.surface.d_phi_deg, 5.0);
  EXPECT_DOUBLE_EQ(dut.pipeline.reliability.tau_kappa, 0.5);
  EXPECT_EQ(dut.pipeline.detector.tau_p, 2);
  EXPECT_DOUBLE_EQ(dut.pipeline.memory.tau_r, 0.75);
  EXPECT_FALSE(dut.pipeline.recognize_partial);
}

TEST_F(ConfigTest, OverrideWinsOverFile) {
  const fs::path file = Write("[memory]\ntau_r = 0.75\n");
  const Settings dut = LoadSettings(file, {"memory.tau_r=2.5", "detection.tau_n = 4"});
  EXPECT_DOUBLE_EQ(dut.pipeline.memory.tau_r, 2.5);
  EXPECT_EQ(dut.pipeline.detector.tau_n, 4);
}

TEST_F(ConfigTest, UnknownKeyNamesFileAndKey) {
  const std::string msg = ErrorOf("[memory]\ntau_q = 1\n");
  EXPECT_NE(msg.find("test.ini"), std::string::npos) << msg;
  EXPECT_NE(msg.find("memory.tau_q"), std::string::npos) << msg;
}

TEST_F(ConfigTest, UnknownOverrideNamesKey) {
  const std::string msg = ErrorOf("", {"detection.nope=1"});
  EXPECT_NE(msg.find("--set"), std::string::npos) << msg;
  EXPECT_NE(msg.find("detection.nope"), std::string::npos) << msg;
}

TEST_F(ConfigTest, OutOfRangeNamesKeyAndRange) {
  const std::string msg = ErrorOf("[detection]\ntau_kappa = 2\n");
  EXPECT_NE(msg.find("test.ini"), std::string::npos) << msg;
  EXPECT_NE(msg.find("detection.tau_kappa"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[0, 1]"), std::string::npos) << msg;
  const std::string open = ErrorOf("[memory]\ntau_h = 1\n");
  EXPECT_NE(open.find("memory.tau_h"), std::string::npos) << open;
  EXPECT_NE(open.find("[0, 1)"), std::string::npos) << open;
}

// The range a key shows is what it accepts: each closed end, written as `tsc config` prints it,
// is read back (sim.start_frame's top, 1e15, was printed as "1e+15" and refused as not whole).
TEST_F(ConfigTest, EveryClosedEndOfAShownRangeIsAccepted) {
  int ends = 0;
  for (const ConfigKey& k : ConfigTable()) {
    if (k.kind != ConfigKey::Kind::kInteger && k.kind != ConfigKey::Kind::kReal) continue;
    if (k.range.min >= k.range.max) continue;  // no numeric range declared
    for (const auto& [value, open] :
         {std::pair{k.range.min, k.range.min_open}, std::pair{k.range.max, k.range.max_open}}) {
      if (open) continue;
      Settings read;
      const std::string assignment = k.key + "=" + FormatRangeNumber(value);
      EXPECT_NO_THROW(ApplyOverride(assignment, read)) << assignment;
      ++ends;
    }
  }
  EXPECT_GT(ends, 100);  // the table's numeric keys were walked
}

// Keys that only fail together are refused when the configuration is read, naming them, so
// tscd exits 78; they used to stop the pipeline's construction with exit 1 (session 82's sweep
// of every key's range ends).
TEST_F(ConfigTest, KeysThatConflictAreRefusedWhenRead) {
  // A grid of 90° steps has 4 pan steps, too few for 9 pan harmonics.
  const std::string grid = ErrorOf("[bubble]\nd_phi_deg = 90\n");
  EXPECT_NE(grid.find("descriptor.harmonics_pan (H1) = 9"), std::string::npos) << grid;
  EXPECT_NE(grid.find("bubble.d_phi_deg"), std::string::npos) << grid;
  // A grid finer than 0.5° (0.001° asked for 10¹⁰ cells and ended in bad_alloc).
  const std::string fine = ErrorOf("[bubble]\nd_phi_deg = 0.001\n");
  EXPECT_NE(fine.find("bubble.d_phi_deg"), std::string::npos) << fine;
  EXPECT_EQ(ErrorOf("[bubble]\nd_phi_deg = 0.5\n"), "");
}

// Ranges the Options structs check in Validate() are declared once, beside the option: the
// table shows and applies that declaration, and a value just outside it is refused by both.
TEST_F(ConfigTest, ValidatedRangesAreTheOptionsOwn) {
  struct Case {
    const char* key;
    Range range;
    std::function<void(Settings&, double)> set;
  };
  const std::vector<Case> cases = {
      {"detection.tau_n", DetectorOptions::kTauNRange,
       [](Settings& s, double v) { s.pipeline.detector.tau_n = static_cast<int>(v); }},
      {"detection.tau_sigma", ReliabilityOptions::kTauSigmaRange,
       [](Settings& s, double v) { s.pipeline.reliability.tau_sigma = v; }},
      {"bubble.patch_px", BubbleSurfaceOptions::kPatchPxRange,
       [](Settings& s, double v) { s.pipeline.surface.patch_px = static_cast<int>(v); }},
      {"descriptor.harmonics_pan", DescriptorOptions::kHarmonicsRange,
       [](Settings& s, double v) { s.pipeline.descriptor.h1 = static_cast<int>(v); }},
      {"pipeline.whereabouts_points", PipelineOptions::kWhereaboutsPointsRange,
       [](Settings& s, double v) { s.pipeline.whereabouts_points = static_cast<int>(v); }},
      {"daemon.queue_frames", DaemonOptions::kQueueFramesRange,
       [](Settings& s, double v) { s.daemon.queue_frames = static_cast<int>(v); }},
      {"lcm.portion_bytes", BusOptions::kPortionBytesRange,
       [](Settings& s, double v) { s.daemon.bus.portion_bytes = static_cast<int>(v); }},
      {"camera.fps", CameraOptions::kFpsRange,
       [](Settings& s, double v) { s.daemon.camera.fps = v; }},
      {"store.budget_mb", StoreOptions::kBudgetMbRange,
       [](Settings& s, double v) { s.daemon.store.budget_mb = static_cast<int64_t>(v); }},
      {"store.maintenance_pages", StoreOptions::kMaintenancePagesRange,
       [](Settings& s, double v) { s.daemon.store.maintenance_pages = static_cast<int>(v); }},
  };
  for (const Case& c : cases) {
    const ConfigKey* k = FindConfigKey(c.key);
    ASSERT_NE(k, nullptr) << c.key;
    EXPECT_EQ(k->RangeText(), c.range.Text()) << c.key;
    for (const double outside : {c.range.min - 1, c.range.max + 1}) {
      Settings direct;
      c.set(direct, outside);
      EXPECT_ANY_THROW({
        direct.pipeline.Validate();
        direct.daemon.Validate();
      }) << c.key
         << " = " << outside;
      Settings read;
      EXPECT_THROW(ApplyOverride(std::string(c.key) + "=" + FormatRangeNumber(outside), read),
                   ConfigError)
          << c.key << " = " << outside;
    }
  }
}

// An LCM URL that LCM cannot open is refused when read, naming lcm.url and the part at fault;
// tscd used to start and then blame a missing multicast route (exit 1).
TEST_F(ConfigTest, AnLcmUrlIsCheckedWhenRead) {
  for (const char* good :
       {"udpm://239.255.76.67:7667?ttl=0", "udpm://239.255.76.67:7667", "udpm://224.0.0.1:7667",
        "udpm://239.1.2.3:1?recv_buf_size=2097152&ttl=255", "memq://"}) {
    Settings read;
    EXPECT_NO_THROW(ApplyOverride(std::string("lcm.url=") + good, read)) << good;
  }
  for (const auto& [bad, part] : std::vector<std::pair<std::string, std::string>>{
           {"udpm://239.255.76.67:99999?ttl=0", "port '99999'"},
           {"udpm://239.255.76.67:0", "port '0'"},
           {"udpm://239.255.76.67?ttl=0", "has no port"},
           {"udpm://239.255.76.67:76x", "port '76x'"},
           {"udpm://192.168.1.10:7667", "'192.168.1.10' is not a multicast group"},
           {"udpm://lcm.local:7667", "'lcm.local' is not a multicast group"},
           {"udpm://239.255.76.67:7667?ttl=300", "ttl '300'"},
           {"udpm://239.255.76.67:7667?recv_buf_size=1&ttl=-1", "ttl '-1'"},
           {"tcp://239.255.76.67:7667", "not a udpm:// or memq:// URL"}}) {
    Settings read;
    try {
      ApplyOverride("lcm.url=" + bad, read);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("lcm.url"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  }
}

TEST_F(ConfigTest, MalformedValuesNameKey) {
  for (const char* text :
       {"[detection]\ntau_n = 2.5\n", "[detection]\ntau_n = three\n", "[memory]\ntau_r = \n",
        "[pipeline]\nrecognize_partial = maybe\n", "[bubble]\nfeatures = L9\n"}) {
    const std::string msg = ErrorOf(text);
    EXPECT_FALSE(msg.empty()) << text;
    const std::string key = std::string(text).substr(1, std::string(text).find(']') - 1);
    EXPECT_NE(msg.find(key + "."), std::string::npos) << msg;
  }
}

// A config file's bytes quoted in an error keep no control byte (an escape sequence would act
// on the terminal or journal that shows the error): they are written as \xNN.
TEST_F(ConfigTest, ControlBytesOfAFileAreEscapedInItsErrors) {
  for (const std::string& text :
       {std::string("[memory]\n\x1b[2Jtau_r = 1\n"), std::string("[memory]\ntau_r = 1\x07\n"),
        std::string("\x01\x02 garbage\n")}) {
    const std::string msg = ErrorOf(text);
    ASSERT_FALSE(msg.empty()) << "accepted";
    for (const char c : msg) {
      const auto byte = static_cast<unsigned char>(c);
      EXPECT_TRUE(byte >= 0x20 && byte != 0x7F) << "control byte " << int{byte} << " in " << msg;
    }
    EXPECT_NE(msg.find("\\x"), std::string::npos) << msg;
  }
}

TEST_F(ConfigTest, RepeatedKeyIsAnError) {
  const std::string msg = ErrorOf("[memory]\ntau_r = 1\ntau_r = 2\n");
  EXPECT_NE(msg.find("memory.tau_r"), std::string::npos) << msg;
}

// camera.max_image_pixels (issue 18): a positive pixel count, 4096x4096 by default, and an
// Axis or V4L2 camera may not be asked for frames it would then refuse.
TEST_F(ConfigTest, ImageLimitIsCheckedAgainstTheRequestedCameraSize) {
  EXPECT_EQ(Settings{}.daemon.camera.max_image_pixels, 4096 * 4096);
  const std::string zero = ErrorOf("[camera]\nmax_image_pixels = 0\n");
  EXPECT_NE(zero.find("camera.max_image_pixels"), std::string::npos) << zero;
  const std::vector<std::string> axis = {"camera.source=axis", "camera.axis_host=cam",
                                         "camera.width=1024", "camera.height=768",
                                         "camera.max_image_pixels=786431"};
  try {
    LoadSettings(std::nullopt, axis);
    FAIL() << "1024x768 over a limit of 786431 pixels must be refused";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.max_image_pixels"), std::string::npos) << e.what();
  }
  std::vector<std::string> fits = axis;
  fits.back() = "camera.max_image_pixels=786432";
  EXPECT_NO_THROW(LoadSettings(std::nullopt, fits));
}

// memory.view_basis: the builtin basis by default, none, or a file of `tsc basis`; a file that
// is missing or not a basis is a configuration error naming the key.
TEST_F(ConfigTest, ViewBasisIsBuiltinNoneOrAFile) {
  EXPECT_EQ(FindConfigKey("memory.view_basis")->get(Settings{}), "builtin");
  const Settings none = LoadSettings(std::nullopt, {"memory.view_basis=none"});
  EXPECT_EQ(none.pipeline.memory.view_basis, nullptr);
  EXPECT_EQ(FindConfigKey("memory.view_basis")->get(none), "none");

  const fs::path file = dir_ / "basis.bin";
  {
    const std::vector<uint8_t> bytes = ViewBasisBytes(Eigen::MatrixXf::Identity(2, 5));
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
  }
  const Settings from_file = LoadSettings(std::nullopt, {"memory.view_basis=" + file.string()});
  ASSERT_NE(from_file.pipeline.memory.view_basis, nullptr);
  EXPECT_EQ(from_file.pipeline.memory.view_basis->dimension(), 2);
  EXPECT_EQ(FindConfigKey("memory.view_basis")->get(from_file), file.string());

  std::ofstream(dir_ / "junk.bin") << "not a basis";
  for (const fs::path& bad : {dir_ / "absent.bin", dir_ / "junk.bin"}) {
    const std::string msg = ErrorOf("[memory]\nview_basis = " + bad.string() + "\n");
    EXPECT_NE(msg.find("memory.view_basis"), std::string::npos) << msg;
    EXPECT_NE(msg.find(bad.filename().string()), std::string::npos) << msg;
  }
}

TEST_F(ConfigTest, MissingFileNamesIt) {
  try {
    LoadSettings(dir_ / "absent.ini", {});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.ini"), std::string::npos) << e.what();
  }
}

TEST_F(ConfigTest, DumpLoadsBackToTheSameOptions) {
  Settings changed;
  ApplyOverride("memory.tau_r=0.333", changed);
  ApplyOverride("bubble.rest_radius=0.1", changed);
  const std::string dump = DumpConfig(changed);
  const Settings dut = LoadSettings(Write(dump), {});
  for (const ConfigKey& k : ConfigTable()) EXPECT_EQ(k.get(dut), k.get(changed)) << k.key;
  EXPECT_NE(dump.find("[detection]"), std::string::npos);
  EXPECT_NE(dump.find("range: [0, 1]"), std::string::npos);
}

// config/tscd.ini documents the defaults; it must list every key with the built-in default.
// After changing a default in an Options struct, regenerate it:
//   build/bin/tsc config > config/tscd.ini
TEST_F(ConfigTest, ShippedFileMatchesTheDefaults) {
  const fs::path shipped = fs::path(TSCD_SOURCE_DIR) / "config" / "tscd.ini";
  const Settings dut = LoadSettings(shipped, {});
  const Settings defaults;
  std::ifstream in(shipped);
  std::stringstream text;
  text << in.rdbuf();
  for (const ConfigKey& k : ConfigTable()) {
    EXPECT_EQ(k.get(dut), k.get(defaults))
        << k.key << " in config/tscd.ini differs from the built-in default; regenerate it with "
        << "`build/bin/tsc config > config/tscd.ini`";
    const std::string name = k.key.substr(k.key.find('.') + 1);
    EXPECT_NE(text.str().find("\n" + name + " = "), std::string::npos) << k.key;
  }
  // The key descriptions and ranges too: the file is exactly what `tsc config` writes.
  EXPECT_EQ(text.str(), DumpConfig(defaults))
      << "config/tscd.ini is not what `tsc config` writes; regenerate it with "
      << "`build/bin/tsc config > config/tscd.ini`";
}

}  // namespace
}  // namespace tsc
