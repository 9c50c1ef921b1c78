// Fuzz target: one file of a dataset folder (TSCD_FUZZ_FILE: camera.json, groundtruth.csv,
// revisits.csv, groundtruth.bmp, or a frame image), read by Dataset::Open (and Load for images) as
// `tsc run`, `tsc eval` and the folder camera read it. Any input must load or be refused with a
// DatasetError.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "drivers/dataset/dataset.h"
#include "fuzz/fuzz_target.h"

namespace fs = std::filesystem;

namespace {

// A folder with three small frames, removed at exit; the fuzzed file is written into it for
// each input.
struct Scratch {
  // The pid at a fixed width: paths of one length take the same code paths in every run.
  fs::path folder = fs::temp_directory_path() / ("tscd-dataset-fuzz-" + tsc::fuzz::FixedWidthPid());
  Scratch() {
    fs::create_directories(folder);
    const cv::Mat frame(24, 32, CV_8UC3, cv::Scalar(40, 90, 160));
    for (const char* name : {"1.png", "2.png", "3.png"}) {
      cv::imwrite((folder / name).string(), frame);
    }
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(folder, ec);
  }
};

const fs::path& Folder() {
  static const Scratch scratch;
  return scratch.folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path file = Folder() / TSCD_FUZZ_FILE;
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const tsc::Dataset dataset = tsc::Dataset::Open(Folder());
    // The fuzzed frame (0.png sorts first, so Open has decoded it once) goes through Load
    // too; the other frames are fixed.
    if (std::string(TSCD_FUZZ_FILE) == "0.png") (void)dataset.Load(0);
  } catch (const tsc::DatasetError&) {
  }
  return 0;
}
