#include "drivers/dataset/json_reader.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace tsc {
namespace {

class JsonReader {
 public:
  explicit JsonReader(const std::string& text) : s_(text) {}

  /// Throws std::runtime_error("invalid JSON at byte N: ...").
  JsonValue Parse() {
    JsonValue v = Value(0);
    if (Peek() != '\0') Error("text after the value");
    return v;
  }

 private:
  [[noreturn]] void Error(const std::string& what) const {
    throw std::runtime_error("invalid JSON at byte " + std::to_string(i_) + ": " + what);
  }
  char Peek() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
    return i_ < s_.size() ? s_[i_] : '\0';
  }
  void Expect(char c) {
    if (Peek() != c) Error(std::string("expected '") + c + "'");
    ++i_;
  }
  JsonValue Value(int depth) {
    if (depth > 64) Error("nested too deeply");
    JsonValue v;
    const char c = Peek();
    if (c == '{') {
      v.kind = JsonValue::Kind::kObject;
      ++i_;
      if (Peek() == '}') {
        ++i_;
        return v;
      }
      while (true) {
        v.keys.push_back(String());
        Expect(':');
        v.items.push_back(Value(depth + 1));
        if (Peek() == '}') break;
        Expect(',');
      }
      ++i_;
    } else if (c == '[') {
      v.kind = JsonValue::Kind::kArray;
      ++i_;
      if (Peek() == ']') {
        ++i_;
        return v;
      }
      while (true) {
        v.items.push_back(Value(depth + 1));
        if (Peek() == ']') break;
        Expect(',');
      }
      ++i_;
    } else if (c == '"') {
      v.kind = JsonValue::Kind::kString;
      v.text = String();
    } else if (c == 't' || c == 'f' || c == 'n') {
      for (const char* w : {"true", "false", "null"}) {
        const size_t n = std::char_traits<char>::length(w);
        if (s_.compare(i_, n, w) == 0) {
          i_ += n;
          v.kind = w[0] == 'n' ? JsonValue::Kind::kNull : JsonValue::Kind::kBool;
          v.boolean = w[0] == 't';
          return v;
        }
      }
      Error("expected a value");
    } else {
      v.kind = JsonValue::Kind::kNumber;
      v.number = Number();
    }
    return v;
  }
  std::string String() {
    Expect('"');
    std::string out;
    while (i_ < s_.size() && s_[i_] != '"') {
      if (s_[i_] == '\\') ++i_;
      if (i_ < s_.size()) out += s_[i_++];
    }
    if (i_ >= s_.size()) Error("unterminated string");
    ++i_;
    return out;
  }
  double Number() {
    const char* begin = s_.c_str() + i_;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin) Error("expected a value");
    i_ += static_cast<size_t>(end - begin);
    if (!std::isfinite(v)) Error("number out of range");
    return v;
  }

  const std::string& s_;
  size_t i_ = 0;
};

}  // namespace

const JsonValue* JsonValue::Find(const std::string& key) const {
  for (size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] == key) return &items[i];
  }
  return nullptr;
}

JsonValue ParseJson(const std::string& text) { return JsonReader(text).Parse(); }

}  // namespace tsc
