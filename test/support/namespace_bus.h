#pragma once
// The LCM bus of every test and whole-program benchmark that runs tscd: multicast that stays
// on the private namespace's lo (ttl 0; test/support/in_netns, DESIGN §4), so nothing reaches
// another host.

namespace tsc::testing_support {

inline constexpr const char* kNamespaceBusUrl = "udpm://239.255.76.67:7667?ttl=0";

}  // namespace tsc::testing_support
