#include "tools/soak_plot.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <string>

namespace tsc {
namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kText(30, 30, 30);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kAxis(90, 90, 90);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kBinS = 10.0;  // CPU and message rates: means over 10 s bins
const double kGap = std::numeric_limits<double>::quiet_NaN();

// Robot colours (BGR), distinct on white.
cv::Scalar RobotColour(int robot) {
  static const cv::Scalar colours[] = {
      {180, 119, 31}, {14, 127, 255},  {44, 160, 44},   {40, 39, 214},  {189, 103, 148},
      {75, 86, 140},  {194, 119, 227}, {127, 127, 127}, {34, 189, 188}, {207, 190, 23}};
  return colours[static_cast<size_t>(robot - 1) % std::size(colours)];
}

void Text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.45,
          const cv::Scalar& colour = kText) {
  cv::putText(img, s, at, kFont, scale, colour, 1, cv::LINE_AA);
}

int TextWidth(const std::string& s, double scale = 0.45) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, 1, &baseline).width;
}

std::string Fixed(double v, int decimals) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}

// A tick step of 1, 2 or 5 × 10^k giving about `target` ticks over `range`.
double NiceStep(double range, int target) {
  if (!(range > 0)) return 1.0;
  const double raw = range / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= raw) return m * p;
  }
  return 10 * p;
}

struct Series {
  std::string name;
  cv::Scalar colour;
  std::vector<cv::Point2d> points;  // (t in s, value); NaN value: a gap
};

void DashedVertical(cv::Mat& img, int x, int y0, int y1, const cv::Scalar& colour) {
  for (int y = y0; y < y1; y += 8) cv::line(img, {x, y}, {x, std::min(y + 4, y1)}, colour, 1);
}

// One panel: title, y axis with unit, grid, the series, restarts as dashed lines.
void DrawPanel(cv::Mat& img, const cv::Rect& area, const std::string& title,
               const std::vector<Series>& series, double t_max,
               const std::vector<SoakRestart>& restarts, bool time_labels) {
  double y_max = 0.0;
  for (const Series& s : series) {
    for (const cv::Point2d& p : s.points) {
      if (std::isfinite(p.y)) y_max = std::max(y_max, p.y);
    }
  }
  const double y_step = NiceStep(y_max > 0 ? y_max : 1.0, 4);
  const double y_top = std::max(y_step, std::ceil(y_max * 1.05 / y_step) * y_step);
  const cv::Rect plot(area.x + 70, area.y + 24, area.width - 90, area.height - 44);
  auto px = [&](double t, double y) {
    return cv::Point(plot.x + static_cast<int>(std::lround(t / t_max * plot.width)),
                     plot.y + plot.height - static_cast<int>(std::lround(y / y_top * plot.height)));
  };
  Text(img, title, {area.x + 8, area.y + 16}, 0.5);
  const int decimals = y_step < 1 ? (y_step < 0.1 ? 2 : 1) : 0;
  for (double y = 0; y <= y_top + 1e-9; y += y_step) {
    const cv::Point a = px(0, y);
    cv::line(img, a, {plot.x + plot.width, a.y}, kGrid, 1);
    const std::string label = Fixed(y, decimals);
    Text(img, label, {plot.x - 6 - TextWidth(label, 0.4), a.y + 4}, 0.4);
  }
  const double minutes = t_max / 60.0;
  const double t_step = NiceStep(minutes, 10) * 60.0;
  for (double t = 0; t <= t_max + 1e-9; t += t_step) {
    const cv::Point a = px(t, 0);
    cv::line(img, {a.x, plot.y}, {a.x, plot.y + plot.height}, kGrid, 1);
    if (time_labels) {
      const std::string label = Fixed(t / 60.0, t_step < 60 ? 1 : 0);
      Text(img, label, {a.x - TextWidth(label, 0.4) / 2, plot.y + plot.height + 16}, 0.4);
    }
  }
  for (const SoakRestart& r : restarts) {
    const int x = px(r.t_s, 0).x;
    DashedVertical(img, x, plot.y, plot.y + plot.height, RobotColour(r.robot));
  }
  for (const Series& s : series) {
    for (size_t i = 1; i < s.points.size(); ++i) {
      const cv::Point2d& a = s.points[i - 1];
      const cv::Point2d& b = s.points[i];
      if (!std::isfinite(a.y) || !std::isfinite(b.y)) continue;
      // Aliased: a few colours keep the PNG small (docs/img), and 2 px lines read well.
      cv::line(img, px(a.x, a.y), px(b.x, b.y), s.colour, 2, cv::LINE_8);
    }
  }
  cv::rectangle(img, plot, kAxis, 1);
  // Legend of this panel, right-aligned in the title line.
  int x = area.x + area.width - 20;
  for (auto it = series.rbegin(); it != series.rend(); ++it) {
    x -= TextWidth(it->name, 0.42) + 30;
    cv::line(img, {x, area.y + 12}, {x + 20, area.y + 12}, it->colour, 3);
    Text(img, it->name, {x + 24, area.y + 17}, 0.42);
  }
}

// Per robot: the value of `get` at each alive sample (with the robot's counters when
// `needs_stats`), a gap while down.
std::vector<Series> PerRobot(const std::vector<SoakSample>& samples, int team_size,
                             const std::function<double(const SoakSample&)>& get,
                             bool needs_stats) {
  std::vector<Series> out;
  for (int r = 1; r <= team_size; ++r) {
    Series s{"robot " + std::to_string(r), RobotColour(r), {}};
    for (const SoakSample& x : samples) {
      if (x.robot != r) continue;
      const bool known = x.alive && (!needs_stats || x.stats_age_s >= 0);
      s.points.emplace_back(x.t_s, known ? get(x) : kGap);
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

cv::Mat DrawSoak(const std::vector<SoakSample>& samples, const std::vector<SoakRestart>& restarts,
                 int team_size) {
  double t_max = 1.0;
  for (const SoakSample& s : samples) t_max = std::max(t_max, s.t_s);
  const int width = 1200, panel = 210, header = 56, footer = 40;
  const int panels = 6;
  cv::Mat img(header + panels * panel + footer, width, CV_8UC3, kWhite);

  // Header: what, and the restart marks.
  int kills = 0, terms = 0, own = 0;
  for (const SoakRestart& r : restarts) {
    (r.signal == "KILL" ? kills : r.signal == "TERM" ? terms : own) += 1;
  }
  Text(img,
       "tsc soak: " + std::to_string(team_size) + " robots, " + Fixed(t_max / 60.0, 1) +
           " min; dashed lines: restarts in the robot's colour (" + std::to_string(terms) +
           " SIGTERM, " + std::to_string(kills) + " SIGKILL" +
           (own > 0 ? ", " + std::to_string(own) + " exited on their own" : "") + ")",
       {16, 24}, 0.55);

  // RSS is measured by the soak itself (/proc), so it is known before the first stats.
  const std::vector<Series> rss = PerRobot(
      samples, team_size, [](const SoakSample& s) { return s.rss_mb; }, false);
  // Places per room when the world's rooms are known (a simulated world's ground truth).
  const int rooms = samples.empty() ? 0 : samples.front().rooms;
  const std::vector<Series> places = PerRobot(
      samples, team_size,
      [rooms](const SoakSample& s) {
        return rooms > 0 ? PlacesPerRoom(s) : static_cast<double>(s.places);
      },
      true);
  const std::vector<Series> database = PerRobot(
      samples, team_size, [](const SoakSample& s) { return s.db_mb; }, false);

  // CPU and merges need the robot's earlier lives: CPU as 10 s means, merges summed over lives.
  std::vector<Series> cpu, merges;
  for (int r = 1; r <= team_size; ++r) {
    Series c{"robot " + std::to_string(r), RobotColour(r), {}};
    Series m{"robot " + std::to_string(r), RobotColour(r), {}};
    std::map<int, int64_t> last_of_life;
    double bin_sum = 0.0;
    int bin_n = 0;
    double bin_start = 0.0;
    for (const SoakSample& x : samples) {
      if (x.robot != r) continue;
      if (x.alive && x.stats_age_s >= 0) {
        last_of_life[x.life] = std::max(last_of_life[x.life], x.merges_completed);
        int64_t total = 0;
        for (const auto& [life, n] : last_of_life) total += n;
        m.points.emplace_back(x.t_s, static_cast<double>(total));
      } else {
        m.points.emplace_back(x.t_s, kGap);
      }
      if (x.t_s >= bin_start + kBinS) {
        c.points.emplace_back(bin_start + kBinS / 2, bin_n > 0 ? bin_sum / bin_n : kGap);
        bin_start += kBinS * std::floor((x.t_s - bin_start) / kBinS);
        bin_sum = 0.0;
        bin_n = 0;
      }
      if (x.alive) {
        bin_sum += x.cpu_percent;
        ++bin_n;
      }
    }
    cpu.push_back(std::move(c));
    merges.push_back(std::move(m));
  }

  // Team message rates per family: counter increments between consecutive samples of one
  // process, summed over robots in 10 s bins.
  // Whole bins only: a last, partial bin would show a rate that fell.
  const size_t bins = static_cast<size_t>(std::floor(t_max / kBinS)) + 1;
  std::vector<std::vector<double>> sent(kSoakFamilies.size(), std::vector<double>(bins, 0.0));
  std::vector<double> received(bins, 0.0);
  std::map<int, const SoakSample*> previous;
  for (const SoakSample& x : samples) {
    if (!x.alive || x.stats_age_s < 0) continue;
    const SoakSample* p = previous[x.robot];
    previous[x.robot] = &x;
    if (p == nullptr || p->life != x.life) continue;
    const size_t bin = static_cast<size_t>(x.t_s / kBinS);
    if (bin + 1 >= bins) continue;
    for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
      sent[k][bin] += static_cast<double>(x.traffic[k].sent - p->traffic[k].sent);
      received[bin] += static_cast<double>(x.traffic[k].received - p->traffic[k].received);
    }
  }
  std::vector<Series> rates;
  const cv::Scalar family_colours[] = {
      {180, 119, 31}, {14, 127, 255}, {44, 160, 44}, {189, 103, 148}, {127, 127, 127}};
  for (size_t k = 0; k < kSoakFamilies.size(); ++k) {
    Series s{std::string(kSoakFamilies[k]) + " sent", family_colours[k], {}};
    for (size_t b = 0; b + 1 < bins; ++b) {
      s.points.emplace_back((static_cast<double>(b) + 0.5) * kBinS, sent[k][b] / kBinS);
    }
    rates.push_back(std::move(s));
  }
  Series recv{"all received", {40, 39, 214}, {}};
  for (size_t b = 0; b + 1 < bins; ++b) {
    recv.points.emplace_back((static_cast<double>(b) + 0.5) * kBinS, received[b] / kBinS);
  }
  rates.push_back(std::move(recv));

  int y = header;
  auto area = [&] {
    const cv::Rect a(0, y, width, panel);
    y += panel;
    return a;
  };
  DrawPanel(img, area(), "resident set (VmRSS), MB", rss, t_max, restarts, false);
  DrawPanel(img, area(), "CPU, % of one core (10 s means)", cpu, t_max, restarts, false);
  DrawPanel(img, area(),
            rooms > 0 ? "places per room (learned places / the " + std::to_string(rooms) +
                            " rooms of the routes)"
                      : std::string("learned places"),
            places, t_max, restarts, false);
  DrawPanel(img, area(), "state database (memory.db and its WAL), MB", database, t_max, restarts,
            false);
  DrawPanel(img, area(), "merges completed (all lives)", merges, t_max, restarts, false);
  DrawPanel(img, area(), "team messages per second (10 s means)", rates, t_max, restarts, true);
  const std::string axis = "time since the soak started, minutes";
  Text(img, axis, {width / 2 - TextWidth(axis, 0.5) / 2, y + 22}, 0.5);
  // Restart marks with their signal, over the first panel.
  for (const SoakRestart& r : restarts) {
    const int x = 70 + static_cast<int>(std::lround(r.t_s / t_max * (width - 90)));
    const std::string mark = r.signal == "KILL" ? "K" : r.signal == "TERM" ? "T" : "X";
    Text(img, mark + std::to_string(r.robot), {x - 8, header - 6}, 0.4, RobotColour(r.robot));
  }
  return img;
}

void WriteSoakPlot(const std::vector<SoakSample>& samples, const std::vector<SoakRestart>& restarts,
                   int team_size, const std::filesystem::path& file) {
  const cv::Mat img = DrawSoak(samples, restarts, team_size);
  bool ok = false;
  try {
    ok = cv::imwrite(file.string(), img, {cv::IMWRITE_PNG_COMPRESSION, 9});
  } catch (const cv::Exception& e) {
    throw std::runtime_error(file.string() + ": cannot write PNG: " + e.what());
  }
  if (!ok) throw std::runtime_error(file.string() + ": cannot write PNG");
}

}  // namespace tsc
