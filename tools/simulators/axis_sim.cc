#include "tools/simulators/axis_sim.h"

#include <sys/socket.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <span>
#include <sstream>
#include <stdexcept>

#include "drivers/camera/http_auth.h"
#include "drivers/image/image_header.h"

namespace tsc {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

constexpr const char* kRealm = "AXIS_SIM";

// A request the simulator refuses: HTTP status and the reason (sent as the body).
struct BadRequest {
  http::status status;
  std::string why;
};

std::map<std::string, std::string> ParseQuery(std::string_view query) {
  std::map<std::string, std::string> out;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? "" : query.substr(amp + 1);
    if (pair.empty()) continue;
    const size_t eq = pair.find('=');
    out[std::string(pair.substr(0, eq))] =
        eq == std::string_view::npos ? "" : std::string(pair.substr(eq + 1));
  }
  return out;
}

double Number(const std::map<std::string, std::string>& q, const std::string& key) {
  const std::string& text = q.at(key);
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw BadRequest{http::status::bad_request, key + "='" + text + "' is not a number\n"};
  }
  return v;
}

int Integer(const std::map<std::string, std::string>& q, const std::string& key, int lo, int hi,
            int fallback) {
  if (!q.count(key)) return fallback;
  const double v = Number(q, key);
  if (v != std::floor(v) || v < lo || v > hi) {
    throw BadRequest{http::status::bad_request,
                     key + "=" + q.at(key) + " must be a whole number in [" + std::to_string(lo) +
                         ", " + std::to_string(hi) + "]\n"};
  }
  return static_cast<int>(v);
}

cv::Size Resolution(const std::map<std::string, std::string>& q) {
  if (!q.count("resolution")) return {640, 480};
  const std::string& text = q.at("resolution");
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 16 || h < 16 || w > 4096 ||
      h > 4096) {
    throw BadRequest{http::status::bad_request,
                     "resolution=" + text + " is not WxH within 16..4096 pixels\n"};
  }
  return {w, h};
}

double WrapDeg(double deg) {
  double w = std::fmod(deg, 360.0);
  if (w > 180.0) w -= 360.0;
  if (w <= -180.0) w += 360.0;
  return w;
}

std::string RandomHex(size_t bytes) {
  std::random_device rd;
  std::string out;
  char b[3];
  for (size_t i = 0; i < bytes; ++i) {
    std::snprintf(b, sizeof b, "%02x", rd() & 0xffu);
    out += b;
  }
  return out;
}

std::string EncodeJpeg(const cv::Mat& bgr, int compression) {
  std::vector<uchar> out;
  cv::imencode(".jpg", bgr, out, {cv::IMWRITE_JPEG_QUALITY, std::max(5, 100 - compression)});
  return std::string(out.begin(), out.end());
}

}  // namespace

std::optional<sim::Pose2> ParsePoseLine(const std::string& line) {
  std::istringstream in(line);
  sim::Pose2 p;
  std::string rest;
  if (!(in >> p.x >> p.y >> p.heading) || (in >> rest)) return std::nullopt;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.heading)) return std::nullopt;
  return p;
}

void AxisSimOptions::Validate() const {
  if (port < 0 || port > 65535) {
    throw std::invalid_argument("axis-sim: port " + std::to_string(port) +
                                " must be in [0, 65535]");
  }
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw std::invalid_argument("axis-sim: hfov_deg must be in (0, 180)");
  }
  if (auth != "none" && auth != "basic" && auth != "digest") {
    throw std::invalid_argument("axis-sim: auth '" + auth + "' is not none, basic or digest");
  }
  if (auth != "none" && (user.empty() || password.empty())) {
    throw std::invalid_argument("axis-sim: auth " + auth + " needs a user and a password");
  }
  if (drop_after_frames < 0) throw std::invalid_argument("axis-sim: drop_after_frames < 0");
  if (bomb_frame < -1) throw std::invalid_argument("axis-sim: bomb_frame < -1");
  if (bomb_every < 0) throw std::invalid_argument("axis-sim: bomb_every < 0");
}

struct AxisSim::Net {
  asio::io_context io;
  tcp::acceptor acceptor{io};
};

struct AxisSim::Connection {
  explicit Connection(asio::io_context& io) : socket(io) {}
  tcp::socket socket;
  std::thread thread;
  std::atomic<bool> done{false};
};

AxisSim::AxisSim(const AxisSimOptions& options)
    : options_((options.Validate(), options)),
      scenario_(sim::MakeScenario([&] {
        sim::SimOptions s;
        s.world = options.world;
        s.seed = options.world_seed;
        return s;
      }())),
      nonce_(RandomHex(16)),
      boundary_("axis-sim-" + RandomHex(6)),
      net_(std::make_unique<Net>()) {
  const sim::Room& first = scenario_.world.rooms().front();
  pose_ = options_.pose.value_or(sim::Pose2{first.cx(), first.cy(), 0.0});
  const tcp::endpoint endpoint(asio::ip::make_address("127.0.0.1"),
                               static_cast<unsigned short>(options_.port));
  beast::error_code ec;
  net_->acceptor.open(endpoint.protocol(), ec);
  if (!ec) net_->acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) net_->acceptor.bind(endpoint, ec);
  if (!ec) net_->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("axis-sim: cannot listen on 127.0.0.1:" +
                             std::to_string(options_.port) + ": " + ec.message());
  }
  port_ = net_->acceptor.local_endpoint().port();
  acceptor_ = std::thread([this] { AcceptLoop(); });
}

AxisSim::~AxisSim() { Stop(); }

void AxisSim::Stop() {
  if (stopping_.exchange(true)) return;
  // shutdown() wakes the threads blocked in accept(), read() or write() on these sockets.
  ::shutdown(net_->acceptor.native_handle(), SHUT_RDWR);
  if (acceptor_.joinable()) acceptor_.join();
  std::vector<std::shared_ptr<Connection>> connections;
  {
    std::lock_guard lock(mutex_);
    connections.swap(connections_);
    for (auto& c : connections) ::shutdown(c->socket.native_handle(), SHUT_RDWR);
  }
  for (auto& c : connections) {
    if (c->thread.joinable()) c->thread.join();
  }
  beast::error_code ec;
  net_->acceptor.close(ec);
}

void AxisSim::SetPose(const sim::Pose2& pose) {
  std::lock_guard lock(mutex_);
  pose_ = pose;
}

double AxisSim::pan_deg() const {
  std::lock_guard lock(mutex_);
  return pan_deg_;
}

double AxisSim::tilt_deg() const {
  std::lock_guard lock(mutex_);
  return tilt_deg_;
}

void AxisSim::AcceptLoop() {
  while (!stopping_) {
    auto connection = std::make_shared<Connection>(net_->io);
    beast::error_code ec;
    net_->acceptor.accept(connection->socket, ec);
    if (ec || stopping_) break;
    std::lock_guard lock(mutex_);
    // Finished connections are joined here, so a long run does not collect threads.
    for (auto it = connections_.begin(); it != connections_.end();) {
      if ((*it)->done) {
        (*it)->thread.join();
        it = connections_.erase(it);
      } else {
        ++it;
      }
    }
    connection->thread = std::thread([this, connection] { Serve(connection); });
    connections_.push_back(connection);
  }
}

const sim::Renderer& AxisSim::RendererFor(int width, int height) {
  std::lock_guard lock(mutex_);
  for (const auto& r : renderers_) {
    if (r->options().width == width && r->options().height == height) return *r;
  }
  sim::RenderOptions render;
  render.width = width;
  render.height = height;
  render.hfov_deg = options_.hfov_deg;
  renderers_.push_back(std::make_unique<sim::Renderer>(scenario_.world, render, 1u));
  return *renderers_.back();
}

sim::Pose2 AxisSim::CurrentPose() {
  std::optional<sim::Pose2> read;
  if (!options_.pose_file.empty()) {
    std::ifstream in(options_.pose_file);
    std::string line;
    if (in && std::getline(in, line)) read = ParsePoseLine(line);
  }
  std::lock_guard lock(mutex_);
  if (read) pose_ = *read;  // else: keep the last pose (the writer may be mid-rename)
  sim::Pose2 p = pose_;
  p.heading -= pan_deg_ * std::numbers::pi / 180.0;  // Axis pan turns clockwise
  return p;
}

bool AxisSim::Authorized(const std::string& authorization, const std::string& method,
                         const std::string& target) const {
  if (options_.auth == "none") return true;
  // Basic or Digest, RFC 7617 / 2617.
  const auto header = ParseAuthHeader(authorization);
  if (header && options_.auth == "basic" && header->scheme == "basic") {
    return Base64Decode(header->token68) == options_.user + ":" + options_.password;
  }
  if (header && options_.auth == "digest" && header->scheme == "digest") {
    const auto p = [&](const char* k) {
      const auto it = header->params.find(k);
      return it == header->params.end() ? std::string() : it->second;
    };
    return p("username") == options_.user && p("realm") == kRealm && p("nonce") == nonce_ &&
           p("uri") == target &&
           p("response") == DigestResponse(options_.user, kRealm, options_.password, method, target,
                                           nonce_, p("nc"), p("cnonce"), p("qop"));
  }
  return false;
}

std::string AxisSim::Challenge() const {
  return options_.auth == "basic" ? std::string("Basic realm=\"") + kRealm + "\""
                                  : std::string("Digest realm=\"") + kRealm + "\", nonce=\"" +
                                        nonce_ + "\", qop=\"auth\", algorithm=MD5";
}

void AxisSim::StreamMjpeg(Connection& connection, const Query& query) {
  const cv::Size size = Resolution(query);
  const int fps = Integer(query, "fps", 1, 60, 10);
  const int compression = Integer(query, "compression", 0, 100, 30);
  const sim::Renderer& renderer = RendererFor(size.width, size.height);
  beast::error_code ec;
  // Axis answers MJPEG as HTTP/1.0 without a length: the stream ends when it closes.
  const std::string head =
      "HTTP/1.0 200 OK\r\nServer: tscd axis-sim\r\n"
      "Cache-Control: no-cache\r\nPragma: no-cache\r\n"
      "Content-Type: multipart/x-mixed-replace; boundary=" +
      boundary_ + "\r\n\r\n";
  asio::write(connection.socket, asio::buffer(head), ec);
  ++streams_opened_;
  const auto period = std::chrono::microseconds(1'000'000 / fps);
  auto due = std::chrono::steady_clock::now();
  for (int n = 0; !ec && !stopping_; ++n) {
    if (options_.drop_after_frames > 0 && n >= options_.drop_after_frames) break;
    cv::Mat bgr;
    renderer.Render(CurrentPose(), &bgr, nullptr);
    std::string jpeg = EncodeJpeg(bgr, compression);
    const bool bomb =
        n == options_.bomb_frame || (options_.bomb_every > 0 && (n + 1) % options_.bomb_every == 0);
    if (bomb) {
      const std::vector<uint8_t> forged = WithClaimedSize(
          std::span(reinterpret_cast<const uint8_t*>(jpeg.data()), jpeg.size()), 20512, 35225);
      jpeg.assign(forged.begin(), forged.end());
    }
    std::string part = "--" + boundary_ + "\r\nContent-Type: image/jpeg\r\n";
    if (!options_.omit_content_length) {
      part += "Content-Length: " + std::to_string(jpeg.size()) + "\r\n";
    }
    part += "\r\n" + jpeg + "\r\n";
    asio::write(connection.socket, asio::buffer(part), ec);
    if (!ec) ++(bomb ? bombs_served_ : frames_served_);
    due += period;
    std::this_thread::sleep_until(due);
  }
}

std::string AxisSim::Snapshot(const Query& query) {
  const cv::Size size = Resolution(query);
  const int compression = Integer(query, "compression", 0, 100, 30);
  cv::Mat bgr;
  RendererFor(size.width, size.height).Render(CurrentPose(), &bgr, nullptr);
  std::string jpeg = EncodeJpeg(bgr, compression);
  ++frames_served_;
  return jpeg;
}

std::string AxisSim::Ptz(const Query& query) {
  std::lock_guard lock(mutex_);
  std::string answer;
  for (const auto& [key, value] : query) {
    if (key == "query" && value == "position") {
      char text[128];
      std::snprintf(text, sizeof text, "pan=%.2f\r\ntilt=%.2f\r\nzoom=%.0f\r\n", pan_deg_,
                    tilt_deg_, zoom_);
      answer = text;
    } else if (key == "pan") {
      pan_deg_ = WrapDeg(Number(query, key));
    } else if (key == "tilt") {
      tilt_deg_ = std::clamp(Number(query, key), -90.0, 90.0);
    } else if (key == "zoom") {
      zoom_ = std::clamp(Number(query, key), 1.0, 9999.0);
    } else if (key == "rpan") {
      pan_deg_ = WrapDeg(pan_deg_ + Number(query, key));
    } else if (key == "rtilt") {
      tilt_deg_ = std::clamp(tilt_deg_ + Number(query, key), -90.0, 90.0);
    } else if (key == "rzoom") {
      zoom_ = std::clamp(zoom_ + Number(query, key), 1.0, 9999.0);
    } else if (key != "camera") {
      throw BadRequest{http::status::bad_request, "ptz.cgi: unsupported parameter '" + key + "'\n"};
    }
  }
  return answer;
}

void AxisSim::Serve(std::shared_ptr<Connection> connection) {
  tcp::socket& socket = connection->socket;
  beast::flat_buffer buffer;
  beast::error_code ec;
  while (!stopping_) {
    http::request<http::string_body> req;
    http::read(socket, buffer, req, ec);
    if (ec) break;
    const std::string target(req.target());
    const size_t qmark = target.find('?');
    const std::string path = target.substr(0, qmark);
    const Query query =
        ParseQuery(qmark == std::string::npos ? "" : std::string_view(target).substr(qmark + 1));
    http::response<http::string_body> res{http::status::ok, req.version()};
    res.set(http::field::server, "tscd axis-sim");
    res.keep_alive(req.keep_alive());
    try {
      if (!Authorized(std::string(req[http::field::authorization]),
                      std::string(req.method_string()), target)) {
        ++unauthorized_;
        res.result(http::status::unauthorized);
        res.set(http::field::www_authenticate, Challenge());
        res.set(http::field::content_type, "text/plain");
        res.body() = "401 Unauthorized\n";
      } else if (path == "/axis-cgi/mjpg/video.cgi") {
        StreamMjpeg(*connection, query);
        break;  // the stream's connection is done
      } else if (path == "/axis-cgi/jpg/image.cgi") {
        res.body() = Snapshot(query);
        res.set(http::field::content_type, "image/jpeg");
      } else if (path == "/axis-cgi/com/ptz.cgi") {
        res.body() = Ptz(query);
        if (res.body().empty()) {
          res.result(http::status::no_content);
        } else {
          res.set(http::field::content_type, "text/plain");
        }
      } else {
        throw BadRequest{http::status::not_found, path + ": not served by axis-sim\n"};
      }
    } catch (const BadRequest& bad) {
      res.result(bad.status);
      res.set(http::field::content_type, "text/plain");
      res.body() = bad.why;
    }
    res.prepare_payload();
    http::write(socket, res, ec);
    if (ec || !res.keep_alive()) break;
  }
  socket.shutdown(tcp::socket::shutdown_both, ec);
  connection->done = true;
}

}  // namespace tsc
