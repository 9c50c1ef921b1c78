#pragma once
// The libFuzzer entry point every target in fuzz/ defines. Built with TSCD_FUZZ=ON (clang)
// libFuzzer drives it; otherwise replay_main.cc runs it over the seed corpus and the
// regression inputs, so the normal test suite replays them too.

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
