#include "drivers/camera/http_auth.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <random>
#include <vector>

namespace tsc {
namespace {

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

void SkipSpace(std::string_view& s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == ',')) {
    s.remove_prefix(1);
  }
}

bool IsTokenChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 ||
         std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

}  // namespace

std::optional<AuthHeader> ParseAuthHeader(std::string_view value) {
  AuthHeader out;
  SkipSpace(value);
  size_t n = 0;
  while (n < value.size() && IsTokenChar(value[n])) ++n;
  if (n == 0) return std::nullopt;
  out.scheme = Lower(value.substr(0, n));
  value.remove_prefix(n);
  if (out.scheme == "basic") {
    // Basic carries one token68 (Base64, which may hold '/', '+' and '=' padding); a Basic
    // challenge carries realm="..." instead.
    SkipSpace(value);
    if (value.find('"') == std::string_view::npos) {
      while (!value.empty() && (value.back() == ' ' || value.back() == '\t'))
        value.remove_suffix(1);
      out.token68 = std::string(value);
      return out;
    }
  }
  while (true) {
    SkipSpace(value);
    if (value.empty()) break;
    size_t k = 0;
    while (k < value.size() && IsTokenChar(value[k])) ++k;
    if (k == 0) return std::nullopt;
    const std::string_view name = value.substr(0, k);
    value.remove_prefix(k);
    while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    if (value.empty() || value.front() != '=') return std::nullopt;
    value.remove_prefix(1);
    std::string v;
    if (!value.empty() && value.front() == '"') {
      value.remove_prefix(1);
      bool closed = false;
      while (!value.empty()) {
        const char c = value.front();
        value.remove_prefix(1);
        if (c == '\\' && !value.empty()) {
          v += value.front();
          value.remove_prefix(1);
        } else if (c == '"') {
          closed = true;
          break;
        } else {
          v += c;
        }
      }
      if (!closed) return std::nullopt;
    } else {
      size_t e = 0;
      while (e < value.size() && value[e] != ',' && value[e] != ' ') ++e;
      v = std::string(value.substr(0, e));
      value.remove_prefix(e);
    }
    out.params[Lower(name)] = v;
  }
  return out;
}

std::string Base64Encode(std::string_view bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<size_t>(n));
  return out;
}

std::optional<std::string> Base64Decode(std::string_view text) {
  if (text.size() % 4 != 0) return std::nullopt;
  std::string out(3 * (text.size() / 4) + 1, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0) return std::nullopt;
  size_t size = static_cast<size_t>(n);
  // EVP_DecodeBlock keeps the zero bytes the padding stands for.
  for (size_t i = text.size(); i > 0 && text[i - 1] == '=' && size > 0; --i) --size;
  out.resize(size);
  return out;
}

std::string Md5Hex(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest, &size, EVP_md5(), nullptr);
  std::string hex;
  char byte[3];
  for (unsigned int i = 0; i < size; ++i) {
    std::snprintf(byte, sizeof byte, "%02x", digest[i]);
    hex += byte;
  }
  return hex;
}

std::string BasicAuthorization(const std::string& user, const std::string& password) {
  return "Basic " + Base64Encode(user + ":" + password);
}

std::string DigestResponse(const std::string& user, const std::string& realm,
                           const std::string& password, const std::string& method,
                           const std::string& uri, const std::string& nonce, const std::string& nc,
                           const std::string& cnonce, const std::string& qop) {
  const std::string ha1 = Md5Hex(user + ":" + realm + ":" + password);
  const std::string ha2 = Md5Hex(method + ":" + uri);
  if (qop.empty()) return Md5Hex(ha1 + ":" + nonce + ":" + ha2);  // RFC 2069 form
  return Md5Hex(ha1 + ":" + nonce + ":" + nc + ":" + cnonce + ":" + qop + ":" + ha2);
}

bool HttpAuthenticator::Challenge(std::string_view www_authenticate) {
  const std::optional<AuthHeader> h = ParseAuthHeader(www_authenticate);
  if (!h) {
    error_ = "malformed WWW-Authenticate '" + std::string(www_authenticate) + "'";
    return false;
  }
  if (h->scheme == "basic") {
    scheme_ = Scheme::kBasic;
    return true;
  }
  if (h->scheme != "digest") {
    error_ = "unsupported authentication scheme '" + h->scheme + "'";
    return false;
  }
  const auto param = [&](const char* name) {
    const auto it = h->params.find(name);
    return it == h->params.end() ? std::string() : it->second;
  };
  const std::string algorithm = Lower(param("algorithm"));
  if (!algorithm.empty() && algorithm != "md5") {
    error_ = "unsupported Digest algorithm '" + param("algorithm") + "' (only MD5)";
    return false;
  }
  const std::string qop = Lower(param("qop"));
  if (!qop.empty() && qop.find("auth") == std::string::npos) {
    error_ = "unsupported Digest qop '" + param("qop") + "' (only auth)";
    return false;
  }
  if (param("nonce").empty()) {
    error_ = "Digest challenge without a nonce";
    return false;
  }
  scheme_ = Scheme::kDigest;
  realm_ = param("realm");
  nonce_ = param("nonce");
  opaque_ = param("opaque");
  qop_ = qop.empty() ? "" : "auth";
  nc_ = 0;
  return true;
}

std::string HttpAuthenticator::Authorization(const std::string& method, const std::string& uri) {
  switch (scheme_) {
    case Scheme::kNone:
      return "";
    case Scheme::kBasic:
      return BasicAuthorization(user_, password_);
    case Scheme::kDigest:
      break;
  }
  char nc[9];
  std::snprintf(nc, sizeof nc, "%08x", ++nc_);
  // The client nonce only has to differ between requests; it is not a secret.
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  char cnonce[33];
  std::snprintf(cnonce, sizeof cnonce, "%016llx%016llx", static_cast<unsigned long long>(rng()),
                static_cast<unsigned long long>(++cnonce_counter_));
  std::string out =
      "Digest username=\"" + user_ + "\", realm=\"" + realm_ + "\", nonce=\"" + nonce_ +
      "\", uri=\"" + uri + "\", algorithm=MD5, response=\"" +
      DigestResponse(user_, realm_, password_, method, uri, nonce_, nc, cnonce, qop_) + "\"";
  if (!qop_.empty()) out += std::string(", qop=auth, nc=") + nc + ", cnonce=\"" + cnonce + "\"";
  if (!opaque_.empty()) out += ", opaque=\"" + opaque_ + "\"";
  return out;
}

}  // namespace tsc
