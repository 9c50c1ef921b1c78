#include "tools/events_json.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace tsc {

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// The three terms of g_N (3.8) and D's agreement with N¹, when one was evaluated (a first
// place is learned without).
std::string TermsJson(const CostTerms& t) {
  if (t.best < 0) return "";
  return ",\"terms\":{\"distance\":" + JsonNumber(t.distance) +
         ",\"ratio\":" + JsonNumber(t.ratio) + ",\"vote\":" + JsonNumber(t.vote) +
         ",\"agreement\":" + JsonNumber(t.agreement) + "}";
}

std::string EventToJson(const PlaceEvent& e) {
  std::string s = "{\"frame\":" + std::to_string(e.frame) +
                  ",\"event\":" + JsonString(EventKindName(e.kind)) +
                  ",\"detected_place\":" + std::to_string(e.detected_place);
  if (e.place) s += ",\"place\":" + JsonString(e.place->ToString());
  switch (e.kind) {
    case EventKind::kDetected:
    case EventKind::kPruned:
      s += ",\"members\":" + std::to_string(e.members);
      break;
    case EventKind::kRecognized:
      s += ",\"cost\":" + JsonNumber(e.cost) + TermsJson(e.terms);
      s += std::string(",\"partial\":") + (e.partial ? "true" : "false");
      s += std::string(",\"hybrid\":") + (e.hybrid ? "true" : "false");
      s += std::string(",\"neighbour\":") + (e.neighbour ? "true" : "false");
      break;
    case EventKind::kLearned:
    case EventKind::kAmbiguous:
      s += ",\"cost\":" + JsonNumber(e.cost) + TermsJson(e.terms);
      if (e.near_miss) s += ",\"near_miss\":true";
      break;
    case EventKind::kMapped:
      if (e.from) s += ",\"from\":" + JsonString(e.from->ToString());
      s += ",\"transition\":";
      s += e.transition.empty() ? std::string("[]")
                                : "[" + std::to_string(e.transition.first) + "," +
                                      std::to_string(e.transition.last) + "]";
      break;
  }
  return s + "}";
}

int WriteEvents(std::ostream& out, const FrameResult& result) {
  for (const PlaceEvent& e : result.events) out << EventToJson(e) << '\n';
  return static_cast<int>(result.events.size());
}

}  // namespace tsc
