// libjpeg's warnings ("Corrupt JPEG data: 3 extraneous bytes before marker 0xd9") through
// tscd's log. tscd decodes JPEG frames with libjpeg (drivers/image/jpeg_decoder.cc), whose
// default error manager prints its warnings to stderr itself, past the log: no time, level or
// robot under a terminal, no priority in the journal. tscd defines jpeg_std_error, which the
// decoder's call binds to (an executable's definition comes first): it sets up libjpeg's own
// manager, then sends its messages to the log as warnings. Errors stay with the decoder, which
// replaces error_exit and reports a frame it cannot decode.

#include <dlfcn.h>
#include <spdlog/spdlog.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>

// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

namespace {

void LogJpegMessage(j_common_ptr cinfo) {
  char text[JMSG_LENGTH_MAX];
  (*cinfo->err->format_message)(cinfo, text);
  spdlog::warn("libjpeg: {}", text);
}

using StdError = jpeg_error_mgr* (*)(jpeg_error_mgr*);

}  // namespace

extern "C" __attribute__((visibility("default"))) jpeg_error_mgr* jpeg_std_error(
    jpeg_error_mgr* err) {
  static const StdError real = reinterpret_cast<StdError>(dlsym(RTLD_NEXT, "jpeg_std_error"));
  if (real == nullptr) {
    std::fprintf(stderr, "tscd: libjpeg's jpeg_std_error not found: %s\n", dlerror());
    std::abort();
  }
  jpeg_error_mgr* out = real(err);
  out->output_message = LogJpegMessage;
  return out;
}
