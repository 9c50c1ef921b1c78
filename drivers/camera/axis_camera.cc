#include "drivers/camera/axis_camera.h"

#include <sys/stat.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <span>
#include <sstream>
#include <stdexcept>

#include "drivers/camera/frame_convert.h"
#include "drivers/camera/http_auth.h"
#include "drivers/camera/multipart_parser.h"
#include "drivers/image/bounded_decode.h"

namespace tsc {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

int64_t Micros(double seconds) { return static_cast<int64_t>(std::llround(seconds * 1e6)); }

// Runs one asynchronous operation on `io` to completion. Beast's stream timeouts
// (expires_after) apply to asynchronous operations only, so every step goes through here.
// Returns operation_aborted within a tenth of a second once `stop` is raised (the camera is
// stopping); the caller then drops `io` and its stream without running it again, so the
// abandoned handler never runs.
template <typename Start>
beast::error_code Await(asio::io_context& io, StopSignal& stop, Start start,
                        size_t* bytes = nullptr) {
  beast::error_code result = asio::error::would_block;
  start([&result, bytes](beast::error_code ec, auto n) {
    result = ec;
    if constexpr (std::is_convertible_v<decltype(n), size_t>) {
      if (bytes != nullptr) *bytes = n;
    }
  });
  io.restart();
  while (result == asio::error::would_block) {
    if (stop.raised()) return asio::error::operation_aborted;
    io.run_for(std::chrono::milliseconds(100));
    if (io.stopped() && result == asio::error::would_block) io.restart();
  }
  return result;
}

std::string Degrees(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// Wraps degrees into (−180, 180].
double WrapDeg(double deg) {
  double w = std::fmod(deg, 360.0);
  if (w > 180.0) w -= 360.0;
  if (w <= -180.0) w += 360.0;
  return w;
}

}  // namespace

void AxisCameraOptions::Validate() const {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("axis camera: " + what);
  };
  if (host.empty()) fail("host is empty");
  if (port < 1 || port > 65535) fail("port " + std::to_string(port) + " must be in [1, 65535]");
  if (user.empty() && !password.empty()) fail("a password is given without a user");
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    fail("resolution " + std::to_string(width) + "x" + std::to_string(height) +
         " must be within 16..8192 pixels each way");
  }
  if (!(fps >= 0.0 && fps <= 1000.0)) fail("fps " + std::to_string(fps) + " must be in [0, 1000]");
  if (compression < 0 || compression > 100) {
    fail("compression " + std::to_string(compression) + " must be in [0, 100]");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    fail("hfov_deg " + std::to_string(hfov_deg) + " must be in (0, 180)");
  }
  if (sweep_steps < 1 || sweep_steps > 360) {
    fail("sweep_steps " + std::to_string(sweep_steps) + " must be in [1, 360]");
  }
  if (!(sweep_deg > 0.0 && sweep_deg <= 360.0)) {
    fail("sweep_deg " + std::to_string(sweep_deg) + " must be in (0, 360]");
  }
  if (!(std::abs(sweep_start_deg) <= 360.0)) {
    fail("sweep_start_deg " + std::to_string(sweep_start_deg) + " must be in [-360, 360]");
  }
  if (!(std::abs(sweep_tilt_deg) <= 90.0)) {
    fail("sweep_tilt_deg " + std::to_string(sweep_tilt_deg) + " must be in [-90, 90]");
  }
  if (!(settle_s >= 0.0 && settle_s <= 60.0)) {
    fail("settle_s " + std::to_string(settle_s) + " must be in [0, 60]");
  }
  if (!(timeout_s > 0.0 && timeout_s <= 600.0)) {
    fail("timeout_s " + std::to_string(timeout_s) + " must be in (0, 600]");
  }
  if (!(reconnect_min_s > 0.0 && reconnect_max_s >= reconnect_min_s && reconnect_max_s <= 3600.0)) {
    fail("reconnect backoff [" + std::to_string(reconnect_min_s) + ", " +
         std::to_string(reconnect_max_s) + "] s must satisfy 0 < min <= max <= 3600");
  }
  if (max_frame_bytes < 1024) fail("max_frame_bytes must be at least 1024");
  if (int64_t{width} * height > max_image_pixels) {
    fail("resolution " + std::to_string(width) + "x" + std::to_string(height) +
         " is more than max_image_pixels " + std::to_string(max_image_pixels));
  }
}

std::string ReadPasswordFile(const std::string& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) {
    throw CameraError("password file " + file + ": cannot be read (" + std::strerror(errno) + ")",
                      false);
  }
  if (!S_ISREG(st.st_mode))
    throw CameraError("password file " + file + ": not a regular file", false);
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", st.st_mode & 0777);
    throw CameraError("password file " + file + ": mode " + mode +
                          " lets others read it; it must be 0600 or 0400 (chmod 600 " + file + ")",
                      false);
  }
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw CameraError("password file " + file + ": cannot be read", false);
  std::string password = text.str();
  while (!password.empty() && (password.back() == '\n' || password.back() == '\r')) {
    password.pop_back();
  }
  if (password.empty()) throw CameraError("password file " + file + ": empty", false);
  return password;
}

struct AxisCamera::Auth {
  explicit Auth(const AxisCameraOptions& o) : authenticator(o.user, o.password) {}
  HttpAuthenticator authenticator;
};

struct AxisCamera::Stream {
  asio::io_context io;
  beast::tcp_stream tcp{io};
  std::optional<MultipartParser> parser;
  std::deque<std::pair<int64_t, std::string>> parts;  // completion time (steady µs), JPEG
  int64_t parts_taken = 0;  // parts taken off `parts` so far: the next one's number, 0-based
};

AxisCamera::AxisCamera(const AxisCameraOptions& options, Clock& clock)
    : options_((options.Validate(), options)),
      clock_(clock),
      intrinsics_(
          CameraIntrinsics::FromHorizontalFov(options.width, options.height, options.hfov_deg)),
      auth_(std::make_unique<Auth>(options)),
      backoff_us_(Micros(options.reconnect_min_s)) {}

AxisCamera::~AxisCamera() = default;

std::string AxisCamera::name() const {
  return "axis:" + options_.host + ":" + std::to_string(options_.port);
}

std::string AxisCamera::StreamTarget() const {
  std::string target = "/axis-cgi/mjpg/video.cgi?resolution=" + std::to_string(options_.width) +
                       "x" + std::to_string(options_.height) +
                       "&compression=" + std::to_string(options_.compression);
  if (options_.fps > 0.0) {
    target += "&fps=" + std::to_string(std::max(1L, std::lround(options_.fps)));
  }
  return target;
}

AxisCamera::Reply AxisCamera::Get(const std::string& target) {
  const std::string what = name() + ": GET " + target;
  for (int attempt = 0;; ++attempt) {
    asio::io_context io;
    beast::tcp_stream tcp(io);
    beast::error_code ec;
    const auto endpoints =
        tcp::resolver(io).resolve(options_.host, std::to_string(options_.port), ec);
    if (ec)
      throw CameraError(what + ": cannot resolve " + options_.host + ": " + ec.message(), true);
    tcp.expires_after(std::chrono::microseconds(Micros(options_.timeout_s)));
    if ((ec = Await(io, interrupted_, [&](auto h) { tcp.async_connect(endpoints, h); }))) {
      throw CameraError(what + ": cannot connect: " + ec.message(), true);
    }
    http::request<http::empty_body> req{http::verb::get, target, 11};
    req.set(http::field::host, options_.host);
    req.set(http::field::user_agent, "tscd");
    req.set(http::field::connection, "close");
    const std::string authorization = auth_->authenticator.Authorization("GET", target);
    if (!authorization.empty()) req.set(http::field::authorization, authorization);
    beast::flat_buffer buffer;
    http::response_parser<http::string_body> parser;
    parser.body_limit(1 << 20);
    if ((ec = Await(io, interrupted_, [&](auto h) { http::async_write(tcp, req, h); })) ||
        (ec = Await(io, interrupted_, [&](auto h) { http::async_read(tcp, buffer, parser, h); }))) {
      throw CameraError(what + ": " + ec.message(), true);
    }
    const auto& res = parser.get();
    if (res.result() != http::status::unauthorized) return Reply{res.result_int(), res.body()};
    if (options_.user.empty()) {
      throw CameraError(what +
                            ": 401, the camera requires credentials (camera.axis_user, "
                            "camera.axis_password_file)",
                        false);
    }
    if (attempt > 0) {
      throw CameraError(
          what + ": 401, the camera rejected the credentials of user '" + options_.user + "'",
          false);
    }
    if (!auth_->authenticator.Challenge(std::string(res[http::field::www_authenticate]))) {
      throw CameraError(what + ": 401 with " + auth_->authenticator.error(), false);
    }
  }
}

PtzPosition AxisCamera::QueryPosition() {
  const Reply reply = Get("/axis-cgi/com/ptz.cgi?query=position");
  if (reply.status / 100 != 2) {
    throw CameraError(name() + ": ptz.cgi?query=position: HTTP " + std::to_string(reply.status),
                      reply.status >= 500);
  }
  PtzPosition out;
  bool pan = false, tilt = false;
  std::istringstream lines(reply.body);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = line.substr(0, eq);
    char* end = nullptr;
    const double v = std::strtod(line.c_str() + eq + 1, &end);
    if (end == line.c_str() + eq + 1 || !std::isfinite(v)) continue;
    if (key == "pan") out.pan_deg = v, pan = true;
    if (key == "tilt") out.tilt_deg = v, tilt = true;
    if (key == "zoom") out.zoom = v;
  }
  if (!pan || !tilt) {
    throw CameraError(
        name() + ": ptz.cgi?query=position: the reply has no " + (pan ? "tilt" : "pan") + "= line",
        true);
  }
  return out;
}

void AxisCamera::MoveAbsolute(double pan_deg, double tilt_deg) {
  const std::string target =
      "/axis-cgi/com/ptz.cgi?pan=" + Degrees(WrapDeg(pan_deg)) + "&tilt=" + Degrees(tilt_deg);
  const Reply reply = Get(target);
  if (reply.status / 100 != 2) {
    throw CameraError(name() + ": " + target + ": HTTP " + std::to_string(reply.status), true);
  }
}

void AxisCamera::MoveRelative(double dpan_deg, double dtilt_deg) {
  const std::string target =
      "/axis-cgi/com/ptz.cgi?rpan=" + Degrees(dpan_deg) + "&rtilt=" + Degrees(dtilt_deg);
  const Reply reply = Get(target);
  if (reply.status / 100 != 2) {
    throw CameraError(name() + ": " + target + ": HTTP " + std::to_string(reply.status), true);
  }
}

PanTilt AxisCamera::ToPanTilt(const PtzPosition& position) const {
  constexpr double kRad = M_PI / 180.0;
  return PanTilt{(options_.pan_clockwise ? -1.0 : 1.0) * position.pan_deg * kRad,
                 position.tilt_deg * kRad};
}

double AxisCamera::SweepPanDeg(int step) const {
  return WrapDeg(options_.sweep_start_deg + step * options_.sweep_deg / options_.sweep_steps);
}

void AxisCamera::Connect() {
  const std::string target = StreamTarget();
  const std::string what = name() + ": GET " + target;
  if (options_.sweep_steps == 1) {
    // Frames are tagged with where the camera looks now; a camera without PTZ looks ahead.
    try {
      position_ = QueryPosition();
    } catch (const CameraError& e) {
      if (!e.recoverable()) throw;
      position_ = PtzPosition{};
    }
  }
  for (int attempt = 0;; ++attempt) {
    auto stream = std::make_unique<Stream>();
    beast::error_code ec;
    const auto endpoints =
        tcp::resolver(stream->io).resolve(options_.host, std::to_string(options_.port), ec);
    if (ec)
      throw CameraError(what + ": cannot resolve " + options_.host + ": " + ec.message(), true);
    stream->tcp.expires_after(std::chrono::microseconds(Micros(options_.timeout_s)));
    if ((ec = Await(stream->io, interrupted_,
                    [&](auto h) { stream->tcp.async_connect(endpoints, h); }))) {
      throw CameraError(what + ": cannot connect: " + ec.message(), true);
    }
    http::request<http::empty_body> req{http::verb::get, target, 11};
    req.set(http::field::host, options_.host);
    req.set(http::field::user_agent, "tscd");
    const std::string authorization = auth_->authenticator.Authorization("GET", target);
    if (!authorization.empty()) req.set(http::field::authorization, authorization);
    beast::flat_buffer buffer;
    http::response_parser<http::empty_body> parser;
    if ((ec = Await(stream->io, interrupted_,
                    [&](auto h) { http::async_write(stream->tcp, req, h); })) ||
        (ec = Await(stream->io, interrupted_,
                    [&](auto h) { http::async_read_header(stream->tcp, buffer, parser, h); }))) {
      throw CameraError(what + ": " + ec.message(), true);
    }
    const auto& res = parser.get();
    if (res.result() == http::status::unauthorized) {
      if (options_.user.empty()) {
        throw CameraError(what +
                              ": 401, the camera requires credentials (camera.axis_user, "
                              "camera.axis_password_file)",
                          false);
      }
      if (attempt > 0 ||
          !auth_->authenticator.Challenge(std::string(res[http::field::www_authenticate]))) {
        throw CameraError(
            what + ": 401, " +
                (attempt > 0 ? "the camera rejected the credentials of user '" + options_.user + "'"
                             : auth_->authenticator.error()),
            false);
      }
      continue;
    }
    if (res.result() != http::status::ok) {
      throw CameraError(
          what + ": HTTP " + std::to_string(res.result_int()) + " (is this an Axis VAPIX camera?)",
          res.result_int() >= 500);
    }
    const std::string content_type(res[http::field::content_type]);
    const std::optional<std::string> boundary = BoundaryFromContentType(content_type);
    if (!boundary) {
      throw CameraError(
          what + ": Content-Type '" + content_type + "' is not multipart with a boundary", false);
    }
    if (parser.chunked()) {
      throw CameraError(what + ": a chunked MJPEG stream is not supported", false);
    }
    MultipartParserOptions parts;
    parts.max_part_bytes = options_.max_frame_bytes;
    stream->parser.emplace(*boundary, parts);
    std::vector<MultipartPart> early;
    stream->parser->Feed(beast::buffers_to_string(buffer.data()), &early);
    for (MultipartPart& p : early) {
      stream->parts.emplace_back(clock_.SteadyMicros(), std::move(p.body));
    }
    stream_ = std::move(stream);
    ++connections_;
    backoff_us_ = Micros(options_.reconnect_min_s);
    return;
  }
}

void AxisCamera::Drop() {
  if (!stream_) return;
  beast::error_code ec;
  stream_->tcp.socket().shutdown(tcp::socket::shutdown_both, ec);
  stream_.reset();
}

void AxisCamera::Lost(const std::string& why) {
  Drop();
  retry_at_us_ = clock_.SteadyMicros() + backoff_us_;
  throw CameraError(
      why + "; reconnecting in " + Degrees(static_cast<double>(backoff_us_) * 1e-6) + " s", true);
}

std::string AxisCamera::NextPart(int64_t not_before_us, int skip_more) {
  for (;;) {
    while (!stream_->parts.empty()) {
      auto [completed_us, body] = std::move(stream_->parts.front());
      stream_->parts.pop_front();
      ++stream_->parts_taken;
      if (completed_us < not_before_us) {
        ++discarded_;
      } else if (skip_more > 0) {
        --skip_more;
        ++discarded_;
      } else {
        return body;
      }
    }
    char chunk[1 << 16];
    size_t n = 0;
    stream_->tcp.expires_after(std::chrono::microseconds(Micros(options_.timeout_s)));
    const beast::error_code ec = Await(
        stream_->io, interrupted_,
        [&](auto h) { stream_->tcp.async_read_some(asio::buffer(chunk), h); }, &n);
    if (ec == asio::error::eof) Lost(name() + ": the camera closed the stream");
    if (ec) Lost(name() + ": stream: " + ec.message());
    std::vector<MultipartPart> parts;
    if (!stream_->parser->Feed(std::string_view(chunk, n), &parts)) {
      Lost(name() + ": stream: " + stream_->parser->error());
    }
    const int64_t now = clock_.SteadyMicros();
    for (MultipartPart& p : parts) stream_->parts.emplace_back(now, std::move(p.body));
    if (stream_->parser->finished()) Lost(name() + ": the camera ended the stream");
  }
}

std::optional<CameraFrame> AxisCamera::Next() {
  if (interrupted_.raised()) return std::nullopt;
  if (!stream_) {
    if (!clock_.WaitUntil(retry_at_us_, interrupted_)) return std::nullopt;
    try {
      Connect();
    } catch (const CameraError& e) {
      if (!e.recoverable()) throw;
      backoff_us_ = std::min(2 * backoff_us_, Micros(options_.reconnect_max_s));
      Lost(e.what());
    }
  }
  const bool sweeping = options_.sweep_steps > 1;
  std::string jpeg;
  try {
    if (sweeping) {
      MoveAbsolute(SweepPanDeg(sweep_step_), options_.sweep_tilt_deg);
      position_ = QueryPosition();
      // Frames completed while the head settles, and the one in flight, show the old view.
      jpeg = NextPart(clock_.SteadyMicros() + Micros(options_.settle_s), 1);
    } else {
      // The camera paces the stream (fps in the request); of several parts read at once only
      // the newest is fresh.
      while (stream_->parts.size() > 1) {
        stream_->parts.pop_front();
        ++stream_->parts_taken;
        ++discarded_;
      }
      jpeg = NextPart(0, 0);
    }
  } catch (const CameraError& e) {
    if (!e.recoverable() || !stream_) throw;  // Lost() already dropped the stream
    Lost(e.what());  // a PTZ request failed: the camera is probably gone too
  }
  // Bounded: a part whose JPEG header claims another size than requested (20512x35225 in a
  // 578-byte part, say) is refused before the decoder allocates for it.
  const int64_t number = stream_->parts_taken - 1;  // of this stream
  ImageLimits limits;
  limits.max_pixels = options_.max_image_pixels;
  limits.exact_size = cv::Size(options_.width, options_.height);
  DecodedImage decoded =
      DecodeBounded(std::span(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size()),
                    PixelLayout::kBgr, limits);
  if (decoded.ok() && decoded.header->format != ImageFormat::kJpeg) {
    decoded.error = "a PNG, not a JPEG";
    decoded.image.release();
  }
  if (!decoded.ok()) {
    ++discarded_;
    ++refused_;
    throw CameraError(name() + ": frame " + std::to_string(number) + " of stream " +
                          std::to_string(connections_) + " (" + std::to_string(jpeg.size()) +
                          " bytes) refused: " + decoded.error,
                      true);
  }
  CameraFrame frame;
  frame.observation.bgr = ToBgrOfSize(decoded.image, intrinsics_);
  frame.observation.pan_tilt = ToPanTilt(position_);
  frame.utime = clock_.WallMicros();
  frame.sequence = delivered_++;
  frame.ends_base_point = !sweeping || sweep_step_ == options_.sweep_steps - 1;
  if (sweeping) sweep_step_ = (sweep_step_ + 1) % options_.sweep_steps;
  return frame;
}

}  // namespace tsc
