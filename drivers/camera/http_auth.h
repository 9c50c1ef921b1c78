#pragma once
// HTTP authentication as Axis cameras use it: Basic (RFC 7617) and Digest with MD5 and
// qop=auth (RFC 7616 / 2617). Both sides: the client answers a challenge, the simulator
// (tools/simulators/axis_sim) issues challenges and checks answers. MD5 and Base64 come from
// OpenSSL.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace tsc {

/// A WWW-Authenticate or Authorization header value: scheme and its parameters
/// (`Digest realm="x", nonce="y", qop="auth"`; for Basic credentials the token is `token68`).
struct AuthHeader {
  std::string scheme;                         ///< lower case: "basic", "digest"
  std::map<std::string, std::string> params;  ///< names lower case, values unquoted
  std::string token68;                        ///< Basic credentials
};

/// Parses one header value; nullopt when it has no scheme. Tolerates unknown parameters.
std::optional<AuthHeader> ParseAuthHeader(std::string_view value);

std::string Base64Encode(std::string_view bytes);
/// nullopt when `text` is not valid Base64.
std::optional<std::string> Base64Decode(std::string_view text);
/// Lower-case hex MD5 of `bytes`.
std::string Md5Hex(std::string_view bytes);

/// `Basic <base64(user:password)>`.
std::string BasicAuthorization(const std::string& user, const std::string& password);

/// The Digest response (RFC 2617 §3.2.2.1) for MD5 with qop=auth, or without qop when `qop`
/// is empty.
std::string DigestResponse(const std::string& user, const std::string& realm,
                           const std::string& password, const std::string& method,
                           const std::string& uri, const std::string& nonce, const std::string& nc,
                           const std::string& cnonce, const std::string& qop);

/// The client side of HTTP authentication: remembers the last challenge so later requests
/// carry credentials without another 401 round trip (Digest counts its nonce uses).
class HttpAuthenticator {
 public:
  HttpAuthenticator(std::string user, std::string password)
      : user_(std::move(user)), password_(std::move(password)) {}

  /// Takes a 401's WWW-Authenticate value. Returns false when no supported scheme (Basic,
  /// Digest with MD5) is offered; the reason is then in error().
  bool Challenge(std::string_view www_authenticate);
  /// The Authorization value for a request, or "" before any challenge.
  std::string Authorization(const std::string& method, const std::string& uri);
  bool has_challenge() const { return scheme_ != Scheme::kNone; }
  const std::string& error() const { return error_; }

 private:
  enum class Scheme { kNone, kBasic, kDigest };
  std::string user_, password_;
  Scheme scheme_ = Scheme::kNone;
  std::string realm_, nonce_, opaque_, qop_;
  uint32_t nc_ = 0;
  uint64_t cnonce_counter_ = 0;
  std::string error_;
};

}  // namespace tsc
