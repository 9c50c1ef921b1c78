#include "drivers/camera/opencv_video.h"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>
#include <system_error>

#include "drivers/camera/camera_source.h"

#ifndef TSCD_OPENCV_VIDEO_MODULE
#error "TSCD_OPENCV_VIDEO_MODULE (the module's path relative to the programs) must be defined"
#endif

namespace tsc {
namespace {

namespace fs = std::filesystem;

template <typename Function>
Function Symbol(void* module, const char* name, const std::string& path) {
  void* address = dlsym(module, name);
  if (address == nullptr) {
    throw CameraError("OpenCV's video module " + path + " has no " + name +
                          " (built from other sources than this program?)",
                      false);
  }
  return reinterpret_cast<Function>(address);
}

OpencvVideoModule Load() {
  const std::string path = OpencvVideoModulePath();
  // Never closed: devices and readers it made may live as long as the process.
  void* module = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (module == nullptr) {
    const char* why = dlerror();
    throw CameraError(
        "cannot load OpenCV's video module (camera.source device or video needs it): " +
            std::string(why != nullptr ? why : path),
        false);
  }
  const int abi = Symbol<int (*)()>(module, "tsc_opencv_video_abi", path)();
  if (abi != kOpencvVideoAbi) {
    throw CameraError("OpenCV's video module " + path + " has interface version " +
                          std::to_string(abi) + ", this program needs " +
                          std::to_string(kOpencvVideoAbi) + " (install them together)",
                      false);
  }
  OpencvVideoModule m;
  m.v4l2_device = Symbol<decltype(m.v4l2_device)>(module, "tsc_opencv_v4l2_device", path);
  m.video_file = Symbol<decltype(m.video_file)>(module, "tsc_opencv_video_file", path);
  return m;
}

}  // namespace

std::string OpencvVideoModulePath() {
  std::error_code ec;
  const fs::path program = fs::read_symlink("/proc/self/exe", ec);
  const fs::path folder = ec ? fs::path(".") : program.parent_path();
  return (folder / TSCD_OPENCV_VIDEO_MODULE).lexically_normal().string();
}

const OpencvVideoModule& OpencvVideo() {
  // Loaded once; a failed load is tried again by the next camera that asks (the file may
  // have been installed meanwhile).
  static std::mutex mutex;
  static OpencvVideoModule module;
  const std::lock_guard<std::mutex> lock(mutex);
  if (module.v4l2_device == nullptr) module = Load();
  return module;
}

}  // namespace tsc
