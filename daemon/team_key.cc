#include "daemon/team_key.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <sys/stat.h>

#include <fstream>
#include <sstream>

namespace tsc {

TeamKey TeamKey::Load(const std::filesystem::path& file) {
  const std::string name = file.string();
  struct stat st {};
  if (stat(file.c_str(), &st) != 0) throw TeamKeyError(name + ": cannot read the team key file");
  if (!S_ISREG(st.st_mode)) throw TeamKeyError(name + ": the team key is not a regular file");
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    std::ostringstream mode;
    mode << std::oct << (st.st_mode & 0777);
    throw TeamKeyError(name + ": the team key file has mode 0" + mode.str() +
                       "; it must be readable by its owner only (chmod 600)");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) throw TeamKeyError(name + ": cannot open the team key file");
  std::stringstream text;
  text << in.rdbuf();
  std::string secret = text.str();
  const size_t b = secret.find_first_not_of(" \t\r\n");
  const size_t e = secret.find_last_not_of(" \t\r\n");
  if (b == std::string::npos) throw TeamKeyError(name + ": the team key file is empty");
  return TeamKey(secret.substr(b, e - b + 1));
}

TeamKey::TeamKey(std::string secret) : secret_(std::move(secret)) {
  if (secret_.empty()) throw TeamKeyError("the team key is empty");
}

HmacTag TeamKey::Sign(const std::vector<uint8_t>& bytes) const {
  HmacTag tag{};
  unsigned int size = 0;
  HMAC(EVP_sha256(), secret_.data(), static_cast<int>(secret_.size()), bytes.data(), bytes.size(),
       tag.data(), &size);
  return tag;
}

bool TeamKey::Verify(const std::vector<uint8_t>& bytes, const uint8_t* tag, size_t tag_size) const {
  if (tag_size != HmacTag{}.size()) return false;
  const HmacTag want = Sign(bytes);
  return CRYPTO_memcmp(want.data(), tag, want.size()) == 0;
}

}  // namespace tsc
