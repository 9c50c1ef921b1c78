// Writes the seed corpus of the fuzz targets that read binary encodings or device streams, from
// the real encoders, into FOLDER/<target>/ (the checked-in fuzz/corpus was made by
// `build/bin/fuzz_make_seeds fuzz/corpus`; the configuration and dataset text seeds are
// written by hand).

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/memory/builtin_view_basis.h"
#include "core/pipeline/pipeline.h"
#include "daemon/lcm_bus.h"
#include "daemon/memory_snapshot.h"
#include "drivers/motor/jaguar_ascii_protocol.h"
#include "drivers/motor/jaguar_v2_protocol.h"
#include "jaguar/motor_command_t.hpp"
#include "test/support/random_memory.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"

namespace fs = std::filesystem;

namespace {

void Write(const fs::path& file, const std::vector<uint8_t>& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error(file.string() + ": cannot write");
}
void Write(const fs::path& file, const std::string& text) {
  Write(file, std::vector<uint8_t>(text.begin(), text.end()));
}

// The read sizes of fuzz/chunked_input.h before a stream: none (one read), or these.
std::string InOneRead(const std::string& stream) { return std::string(1, '\0') + stream; }
std::string InReads(const std::string& stream, std::initializer_list<uint8_t> sizes) {
  std::string s(1, static_cast<char>(sizes.size()));
  for (uint8_t n : sizes) s += static_cast<char>(n);
  return s + stream;
}

// The snapshot assembler's input framing: 4-byte big-endian length, then the encoding.
void AppendFramed(std::vector<uint8_t>& stream, const std::vector<uint8_t>& bytes) {
  const auto n = static_cast<uint32_t>(bytes.size());
  for (int shift : {24, 16, 8, 0}) stream.push_back(static_cast<uint8_t>(n >> shift));
  stream.insert(stream.end(), bytes.begin(), bytes.end());
}

// The exchange's LCM messages: an announce (unsigned, signed), requests, a place event, motor
// commands.
void WriteLcmSeeds(const fs::path& out) {
  using tsc::LcmBus;
  tsc::announce_t a{};
  a.utime = 1700000000000000;
  a.protocol = tsc::announce_t::PROTOCOL;
  a.robot = 2;
  a.boot_id = 77;
  a.sequence = 5;
  a.memory_version = 3;
  a.memory_digest = 0x1234;
  a.portions = 2;
  a.places = 6;
  a.status = "running";
  a.hmac_size = 0;
  Write(out / "fuzz_lcm_announce_t/unsigned", LcmBus::Encode(a));
  a.status = "degraded: store: disk full";
  a.hmac_size = 32;
  a.hmac.assign(32, 0xab);
  Write(out / "fuzz_lcm_announce_t/signed", LcmBus::Encode(a));

  tsc::memory_request_t r{};
  r.requester = 1;
  r.robot = 2;
  r.version = 3;
  r.num_missing = 2;
  r.missing = {0, 3};
  r.hmac_size = 0;
  Write(out / "fuzz_lcm_memory_request_t/missing", LcmBus::Encode(r));
  r.num_missing = 0;
  r.missing.clear();
  Write(out / "fuzz_lcm_memory_request_t/all", LcmBus::Encode(r));

  tsc::place_event_t e{};
  e.robot = 2;
  e.frame = 41;
  e.event = "mapped";
  e.has_place = 1;
  e.place.robot = 2;
  e.place.local = 3;
  e.has_from = 1;
  e.from.robot = 2;
  e.from.local = 2;
  e.transition_first = 30;
  e.transition_last = 40;
  Write(out / "fuzz_lcm_place_event_t/mapped", LcmBus::Encode(e));

  jaguar::motor_command_t c{};
  c.sequence = 9;
  c.linear_mps = 0.3;
  c.angular_radps = -0.2;
  Write(out / "fuzz_lcm_motor_command_t/drive", LcmBus::Encode(c));
  c.estop = 1;
  Write(out / "fuzz_lcm_motor_command_t/estop", LcmBus::Encode(c));
}

// A real memory of 12 places cut into portions: each portion, and the assembler's streams of
// them. Returns the portions.
size_t WriteSnapshotSeeds(const fs::path& out) {
  using tsc::LcmBus;
  // A real memory of 12 places (32 dimensions, 4 members) in portions of at most 4 KiB.
  const auto memory = tsc::testing_support::MakeRandomMemory(2, 12, 32, 1, 4);
  const tsc::MemorySnapshot snapshot =
      tsc::BuildSnapshot(memory.memory, memory.map, tsc::SnapshotHeader{2, 77, 3, 0}, 4096);
  const std::vector<tsc::memory_portion_v2_t> portions = tsc::AllPortions(snapshot);
  std::vector<uint8_t> in_order, shuffled;
  for (size_t i = 0; i < portions.size(); ++i) {
    const std::vector<uint8_t> bytes = LcmBus::Encode(portions[i]);
    Write(out / "fuzz_lcm_memory_portion_v2_t" / ("portion-" + std::to_string(i)), bytes);
    AppendFramed(in_order, bytes);
  }
  for (size_t i = portions.size(); i-- > 0;) {
    const std::vector<uint8_t> bytes = LcmBus::Encode(portions[i]);
    AppendFramed(shuffled, bytes);
    if (i == 0) AppendFramed(shuffled, bytes);  // a duplicate
  }
  Write(out / "fuzz_snapshot_assembler/in-order", in_order);
  Write(out / "fuzz_snapshot_assembler/reversed-with-duplicate", shuffled);

  // The next version after place 5 was seen again: its structure and the one new body, which
  // the assembler completes from the bodies of the first (issue 23).
  auto changed = memory;
  tsc::DetectedPlace revisit;
  revisit.index = 13;
  revisit.descriptors = Eigen::MatrixXf::Constant(32, 2, 0.5f);
  revisit.members = {1300, 1301};
  changed.memory.Update(5, revisit);
  const tsc::MemorySnapshot next =
      tsc::BuildSnapshot(changed.memory, changed.map, tsc::SnapshotHeader{2, 77, 4, 0}, 4096);
  std::vector<uint8_t> two_versions = in_order;
  for (int32_t i :
       tsc::PortionsBeyond(next, {snapshot.body_digests.begin(), snapshot.body_digests.end()})) {
    AppendFramed(two_versions, LcmBus::Encode(next.Portion(i)));
  }
  Write(out / "fuzz_snapshot_assembler/next-version-changed-body-only", two_versions);

  // A memory in tscd's default view basis (descriptors of its input dimension, views on its
  // axes), so that the assembler's memory is restored and merged in the basis, as tscd does.
  const auto in_basis = tsc::testing_support::MakeRandomMemory(
      2, 4, tsc::BuiltinViewBasis()->input_dimension(), 1, 4, tsc::PipelineOptions{}.memory);
  const tsc::MemorySnapshot basis_snapshot =
      tsc::BuildSnapshot(in_basis.memory, in_basis.map, tsc::SnapshotHeader{2, 78, 3, 0}, 60000);
  std::vector<uint8_t> in_basis_stream;
  for (const tsc::memory_portion_v2_t& p : tsc::AllPortions(basis_snapshot)) {
    AppendFramed(in_basis_stream, LcmBus::Encode(p));
  }
  Write(out / "fuzz_snapshot_assembler/builtin-basis", in_basis_stream);
  return portions.size();
}

// A small camera frame.
cv::Mat Frame() { return cv::Mat(24, 32, CV_8UC3, cv::Scalar(40, 90, 160)); }

void WriteImageSeeds(const fs::path& out) {
  for (const char* ext : {".png", ".jpg"}) {
    std::vector<uint8_t> bytes;
    cv::imencode(ext, Frame(), bytes);
    Write(out / "fuzz_dataset_image" / (std::string("frame") + ext), bytes);
  }
}

void WriteJaguarV2Seeds(const fs::path& out) {
  // Jaguar V2/V4 datagrams: the board's three sensor frames and ACK as `tsc jaguar-sim` sends
  // them (tools/simulators/jaguar_sim.cc), the PC's PWM, ACK and ping as JaguarV2Base sends them.
  namespace v2 = tsc::jaguar_v2;
  v2::MotorSensor ms;
  ms.output_pwm = {16384, 16384, 0, 17000, 15800, 0};
  ms.ch0_encoder = 1200;
  ms.ch1_encoder = 64000;
  ms.direction_bits = 0x05;
  v2::CustomSensor cs;
  cs.analog = {0, 2980, 1800, 1810, 1790, 1805, 1795, 1800};
  cs.ch3_encoder = 65500;
  cs.ch4_encoder = 120;
  cs.ch3_velocity = 300;
  cs.ch4_velocity = 310;
  cs.ch4_direction = 1;
  const v2::StandardSensor ss{2275, 2991};
  auto to_pc = [](v2::FrameType type, std::vector<uint8_t> data) {
    return v2::Encode({v2::kDestPc, 0, static_cast<uint8_t>(type), std::move(data)});
  };
  const fs::path v2_dir = out / "fuzz_jaguar_v2_frame";
  Write(v2_dir / "motor-sensor", to_pc(v2::FrameType::kMotorSensor, v2::SerializeMotorSensor(ms)));
  Write(v2_dir / "custom-sensor",
        to_pc(v2::FrameType::kCustomSensor, v2::SerializeCustomSensor(cs)));
  Write(v2_dir / "standard-sensor",
        to_pc(v2::FrameType::kStandardSensor, v2::SerializeStandardSensor(ss)));
  Write(v2_dir / "ack-to-pc", v2::EncodeAck(v2::kDestPc));
  Write(v2_dir / "ack-to-board", v2::EncodeAck());
  Write(v2_dir / "pwm-all-stop", v2::EncodePwmAll(v2::AllStop()));
  Write(v2_dir / "ping-to-board", v2::Encode({v2::kDestBoard,
                                              7,
                                              static_cast<uint8_t>(v2::FrameType::kSystem),
                                              {static_cast<uint8_t>(v2::SystemCommand::kPing)}}));
}

void WriteJaguarAsciiSeeds(const fs::path& out) {
  // Jaguar 4x4/V6 TCP stream: the board's report lines as `tsc jaguar-sim` writes them
  // (tools/simulators/jaguar_sim.cc), then the PC's command lines as JaguarAsciiBase sends them; in
  // one read and cut into small reads.
  namespace ascii = tsc::jaguar_ascii;
  const std::string replies =
      "MM0 C=1234:-5678\r\nMM0 V=120:252:50\r\nMM0 T=28:29\r\nMM0 FF=16\r\n"
      "#17,YAW,0.7854,GYRO,0,0,0.1250,ACC,0,0,9.81,COMP,0.2,0,0.4\r\n"
      "MMW +\r\nMMW -\r\nMM2 +\r\nMM3 -\r\n$GPRMC,123519,A\r\n";
  const std::string commands = ascii::Stop() + ascii::EmergencyStop() + ascii::Release() +
                               ascii::WheelPower(250, -300) + ascii::Ping() +
                               ascii::FlipperMove(2, 1, -400) + "SYS MMC 255\r\n";
  const fs::path ascii_dir = out / "fuzz_jaguar_ascii_line";
  Write(ascii_dir / "replies", InOneRead(replies));
  Write(ascii_dir / "replies-cut", InReads(replies, {1, 5, 17}));
  Write(ascii_dir / "commands", InOneRead(commands));
  Write(ascii_dir / "commands-cut", InReads(commands, {3, 0, 11}));
}

void WriteAxisSeeds(const fs::path& out) {
  // An MJPEG stream as `tsc axis-sim` serves it (tools/simulators/axis_sim.cc): the Content-Type
  // line, then parts with Content-Length, or without (its omit_content_length mode), closed.
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", Frame(), jpeg);
  const std::string boundary = "axis-sim-3fa2b1";
  auto mjpeg = [&](bool with_length) {
    std::string s = "multipart/x-mixed-replace; boundary=" + boundary + "\r\n";
    for (int i = 0; i < 2; ++i) {
      s += "--" + boundary + "\r\nContent-Type: image/jpeg\r\n";
      if (with_length) s += "Content-Length: " + std::to_string(jpeg.size()) + "\r\n";
      s += "\r\n" + std::string(jpeg.begin(), jpeg.end()) + "\r\n";
    }
    return s + "--" + boundary + "--\r\n";
  };
  const fs::path axis_dir = out / "fuzz_axis_multipart";
  Write(axis_dir / "with-length", InOneRead(mjpeg(true)));
  Write(axis_dir / "with-length-cut", InReads(mjpeg(true), {7, 200, 1}));
  Write(axis_dir / "without-length", InOneRead(mjpeg(false)));
  Write(axis_dir / "without-length-cut", InReads(mjpeg(false), {13, 0, 64, 2}));
}

}  // namespace

// Edits (fuzz/sqlite_edits.h) to a database of the store's schema, for fuzz_store and
// fuzz_spill: none, then for each of its 13 tables (by name) a cell's bytes overwritten, a
// cell set to the largest integer, a row deleted; and a learned place's mean set to a NaN real.
void WriteDatabaseEditSeeds(const fs::path& dir) {
  Write(dir / "unchanged", std::vector<uint8_t>{});
  constexpr uint8_t kTables = 13, kLearnedPlaces = 4;
  for (uint8_t t = 0; t < kTables; ++t) {
    const std::string table = std::to_string(t);
    Write(dir / ("overwrite-" + table),
          std::vector<uint8_t>{3, t, 2, 0, 4, 0, 4, 0xFF, 0xFF, 0xFF, 0x7F});
    Write(dir / ("largest-integer-" + table),
          std::vector<uint8_t>{0, t, 1, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F});
    Write(dir / ("delete-" + table), std::vector<uint8_t>{4, t, 0, 0});
  }
  Write(dir / "nan-real",
        std::vector<uint8_t>{1, kLearnedPlaces, 2, 0, 0, 0, 0, 0, 0, 0, 0xF8, 0x7F});
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds FOLDER\n");
    return 2;
  }
  const fs::path out(argv[1]);
  WriteLcmSeeds(out);
  const size_t portions = WriteSnapshotSeeds(out);
  WriteImageSeeds(out);
  WriteJaguarV2Seeds(out);
  WriteJaguarAsciiSeeds(out);
  WriteAxisSeeds(out);
  WriteDatabaseEditSeeds(out / "fuzz_store");
  WriteDatabaseEditSeeds(out / "fuzz_spill");
  std::printf("seeds written to %s (%zu portions)\n", out.c_str(), portions);
  return 0;
}
