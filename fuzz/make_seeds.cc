// Writes the seed corpus of the fuzz targets that read binary encodings, from the real
// encoders, into FOLDER/<target>/ (the checked-in fuzz/corpus was made by
// `build/bin/fuzz_make_seeds fuzz/corpus`; the text targets' seeds are written by hand).

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "daemon/lcm_bus.h"
#include "daemon/memory_snapshot.h"
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

// The snapshot assembler's input framing: 4-byte big-endian length, then the encoding.
void AppendFramed(std::vector<uint8_t>& stream, const std::vector<uint8_t>& bytes) {
  const auto n = static_cast<uint32_t>(bytes.size());
  for (int shift : {24, 16, 8, 0}) stream.push_back(static_cast<uint8_t>(n >> shift));
  stream.insert(stream.end(), bytes.begin(), bytes.end());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds FOLDER\n");
    return 2;
  }
  const fs::path out(argv[1]);
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

  // A real memory of 12 places (32 dimensions, 4 members) in portions of at most 4 KiB.
  const auto memory = tsc::testing_support::MakeRandomMemory(2, 12, 32, 1, 4);
  const tsc::MemorySnapshot snapshot =
      tsc::BuildSnapshot(memory.memory, memory.map, tsc::SnapshotHeader{2, 77, 3, 0}, 4096);
  std::vector<uint8_t> in_order, shuffled;
  for (size_t i = 0; i < snapshot.portions.size(); ++i) {
    const std::vector<uint8_t> bytes = LcmBus::Encode(snapshot.portions[i]);
    Write(out / "fuzz_lcm_memory_portion_t" / ("portion-" + std::to_string(i)), bytes);
    AppendFramed(in_order, bytes);
  }
  for (size_t i = snapshot.portions.size(); i-- > 0;) {
    const std::vector<uint8_t> bytes = LcmBus::Encode(snapshot.portions[i]);
    AppendFramed(shuffled, bytes);
    if (i == 0) AppendFramed(shuffled, bytes);  // a duplicate
  }
  Write(out / "fuzz_snapshot_assembler/in-order", in_order);
  Write(out / "fuzz_snapshot_assembler/reversed-with-duplicate", shuffled);

  const cv::Mat frame(24, 32, CV_8UC3, cv::Scalar(40, 90, 160));
  for (const char* ext : {".png", ".jpg"}) {
    std::vector<uint8_t> bytes;
    cv::imencode(ext, frame, bytes);
    Write(out / "fuzz_dataset_image" / (std::string("frame") + ext), bytes);
  }
  std::printf("seeds written to %s (%zu portions)\n", out.c_str(), snapshot.portions.size());
  return 0;
}
