#pragma once
// A bound on what a received LCM message may make the decoder allocate. lcm-gen's decoders
// size every array from its length field before they check that the elements are there, so
// a forged length of 2³¹ makes a 100-byte datagram allocate gigabytes (found by fuzzing the
// decoders, docs/reliability.md). ArrayLengthsFit<T> walks the encoding of T without
// allocating and checks each length against the bytes left, before decode() runs.

#include <cstddef>
#include <cstdint>

namespace jaguar {
class motor_command_t;
class motor_state_t;
}  // namespace jaguar

namespace tsc {

class announce_t;
class memory_portion_v2_t;
class memory_request_t;
class place_event_t;
class stats_t;

/// True when every array and string length in the encoding `data[0, size)` of T is
/// non-negative and claims no more elements than there are bytes left after it (every element
/// takes at least one byte; rows of a 2-D array whose rows are empty count one each), and every
/// string ends in its only NUL. False when the bytes end early. Does not check the fingerprint or
/// anything decode() checks. Defined for each message type a tscd process decodes from outside.
template <typename T>
bool ArrayLengthsFit(const uint8_t* data, size_t size);

template <>
bool ArrayLengthsFit<announce_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<memory_portion_v2_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<memory_request_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<place_event_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<stats_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<jaguar::motor_command_t>(const uint8_t* data, size_t size);
template <>
bool ArrayLengthsFit<jaguar::motor_state_t>(const uint8_t* data, size_t size);

}  // namespace tsc
