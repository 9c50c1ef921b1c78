#include "drivers/camera/folder_camera.h"

#include <algorithm>
#include <array>
#include <fstream>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace tsc {
namespace fs = std::filesystem;
namespace {

Dataset OpenDataset(const FolderCameraOptions& options) {
  DatasetOptions dataset;
  dataset.max_image_pixels = options.max_image_pixels;
  try {
    // A frame file of zero bytes (a writer that has not written it yet, a full disk) is a bad
    // frame like a truncated one: logged by the daemon, and reading goes on.
    dataset.empty_images = EmptyImages::kLoadFails;
    return Dataset::Open(options.folder, dataset);
  } catch (const DatasetError& e) {
    throw CameraError(std::string("folder camera: ") + e.what(), false);
  }
}

CameraIntrinsics IntrinsicsOf(const Dataset& dataset, double hfov_deg) {
  std::error_code ec;
  if (fs::exists(dataset.folder() / "camera.json", ec)) return dataset.camera();
  return CameraIntrinsics::FromHorizontalFov(dataset.camera().width(), dataset.camera().height(),
                                             hfov_deg);
}

/// Up to `n` bytes from the end of `file` (fewer when the file is shorter).
std::vector<unsigned char> Tail(std::ifstream& in, std::streamoff n) {
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff take = std::min(size, n);
  std::vector<unsigned char> out(static_cast<size_t>(std::max<std::streamoff>(take, 0)));
  in.seekg(size - take);
  in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size()));
  if (!in) out.clear();
  return out;
}

}  // namespace

void FolderCameraOptions::Validate() const {
  if (folder.empty()) throw std::invalid_argument("folder camera: folder is empty");
  if (!(fps >= 0.0 && fps <= 1000.0)) {
    throw std::invalid_argument("folder camera: fps " + std::to_string(fps) +
                                " must be in [0, 1000]");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("folder camera: hfov_deg " + std::to_string(hfov_deg) +
                                " must be in (0, 180)");
  }
  if (max_image_pixels < 1) {
    throw std::invalid_argument("folder camera: max_image_pixels " +
                                std::to_string(max_image_pixels) + " must be at least 1");
  }
}

bool ImageFileLooksComplete(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  std::array<unsigned char, 8> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  if (in.gcount() < 4) return false;
  in.clear();
  const bool jpeg = head[0] == 0xFF && head[1] == 0xD8;
  const bool png = head[0] == 0x89 && head[1] == 'P' && head[2] == 'N' && head[3] == 'G';
  if (!jpeg && !png) return true;
  // Some writers pad after the end marker: look in the last KiB rather than the last bytes.
  const std::vector<unsigned char> tail = Tail(in, 1024);
  if (jpeg) {
    // 0xFF 0xD9 (EOI) cannot occur inside entropy-coded data (0xFF is stuffed as 0xFF 0x00).
    for (size_t i = tail.size(); i-- > 1;) {
      if (tail[i - 1] == 0xFF && tail[i] == 0xD9) return true;
    }
    return false;
  }
  static constexpr std::array<unsigned char, 4> kIend = {'I', 'E', 'N', 'D'};
  return std::search(tail.begin(), tail.end(), kIend.begin(), kIend.end()) != tail.end();
}

FolderCamera::FolderCamera(const FolderCameraOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      dataset_(OpenDataset(options)),
      intrinsics_(IntrinsicsOf(dataset_, options.hfov_deg)),
      pacer_(options.fps, clock) {}

std::optional<CameraFrame> FolderCamera::Next() {
  if (interrupted_.raised()) return std::nullopt;
  if (pending_.empty()) {
    if (next_index_ >= dataset_.size()) {
      if (!options_.loop) return std::nullopt;
      next_index_ = 0;
    }
    const int i = next_index_++;  // advance first: a bad frame is skipped, not retried
    pacer_.Wait(&interrupted_);
    if (interrupted_.raised()) return std::nullopt;
    const fs::path& file = dataset_.image_path(i);
    if (!ImageFileLooksComplete(file)) {
      throw CameraError(name() + ": frame " + std::to_string(i) + " " + file.string() +
                            ": truncated or unreadable image",
                        true);
    }
    try {
      std::vector<Observation> views = dataset_.Load(i);
      pending_.assign(std::make_move_iterator(views.begin()), std::make_move_iterator(views.end()));
    } catch (const DatasetError& e) {
      throw CameraError(name() + ": frame " + std::to_string(i) + " " + e.what(), true);
    }
  }
  // A frame of a sweep dataset is delivered view by view; its last view ends the base point.
  CameraFrame frame;
  frame.observation = std::move(pending_.front());
  pending_.pop_front();
  frame.ends_base_point = pending_.empty();
  frame.utime = clock_.WallMicros();
  frame.sequence = delivered_++;
  return frame;
}

}  // namespace tsc
