#pragma once
// Pipeline events as JSON lines (DESIGN §7.2), one object per PlaceEvent:
//   {"frame":k,"event":"detected","detected_place":m,"members":n}
//   {"frame":k,"event":"recognized","detected_place":m,"place":"1:3","cost":0.41,
//    "terms":{"distance":0.2,"ratio":0.21,"vote":1},"partial":false,"hybrid":true}
//   {"frame":k,"event":"learned","detected_place":m,"place":"1:4","cost":2.7,"terms":{...}}
//   {"frame":k,"event":"mapped","detected_place":m,"place":"1:4","from":"1:3",
//    "transition":[first,last]}
//   {"frame":k,"event":"pruned","detected_place":0,"members":n}
// k is the base point index (0-based; on a fresh store frame i of the dataset is base point
// i); cost is g_N of the last node evaluated (for "learned", the cost that failed τ_r), null
// when not finite; terms are its three terms of (3.8) (left out when no g_N was evaluated: the
// first place); transition is the inclusive base point range, [] when empty.

#include <ostream>
#include <string>

#include "core/pipeline/pipeline.h"

namespace tsc {

/// One event as a single-line JSON object (no trailing newline).
std::string EventToJson(const PlaceEvent& event);

/// `s` as a JSON string literal, quotes included.
std::string JsonString(const std::string& s);
/// Shortest round-trip form of `v`, or null when it is not finite.
std::string JsonNumber(double v);

/// Writes each event of `result` as one line. Returns the number of lines written.
int WriteEvents(std::ostream& out, const FrameResult& result);

}  // namespace tsc
