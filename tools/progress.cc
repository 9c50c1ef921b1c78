#include "tools/progress.h"

#include <unistd.h>

#include <algorithm>
#include <string>

namespace tsc {

ProgressBar::ProgressBar(int64_t total, std::FILE* out, bool force_off)
    : out_(out),
      total_(std::max<int64_t>(total, 1)),
      enabled_(!force_off && out != nullptr && isatty(fileno(out)) == 1),
      start_(Clock::now()),
      last_draw_() {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(int64_t done, const ProgressCounts& counts) {
  if (!enabled_) return;
  const Clock::time_point now = Clock::now();
  if (done < total_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(kWidth * std::min(done, total_) / total_);
  const double seconds = std::chrono::duration<double>(now - start_).count();
  const double fps = seconds > 0 ? static_cast<double>(done) / seconds : 0.0;
  const std::string bar = std::string(filled, '#') + std::string(kWidth - filled, '.');
  std::fprintf(out_,
               "\r[%s] %lld/%lld frames  %.1f frames/s  places: %lld detected, %lld learned, "
               "%lld recognised\033[K",
               bar.c_str(), static_cast<long long>(done), static_cast<long long>(total_), fps,
               static_cast<long long>(counts.detected_places),
               static_cast<long long>(counts.learned_places),
               static_cast<long long>(counts.recognitions));
  std::fflush(out_);
}

void ProgressBar::Finish() {
  if (!enabled_) return;
  std::fprintf(out_, "\r\033[K");
  std::fflush(out_);
  enabled_ = false;
}

}  // namespace tsc
