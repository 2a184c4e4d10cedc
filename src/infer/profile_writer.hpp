// Stage 4 of `profiles infer`: the guesses written as a profile in rtuscope's TOML
// (docs/profiles.md), every register with its evidence as a comment, ready for
// `rtuscope profiles check` and `decode --profile`.
#pragma once

#include <string>

#include "infer/scoring.hpp"

namespace rtuscope::infer {

// "slave-3": the profile's name, and its file's ("slave-3.toml") in a directory.
std::string draft_profile_name(std::uint8_t slave);

// `source`: what the draft was inferred from, for its header ("bus.rtucap").
std::string write_profile(const DeviceGuess& device, const std::string& source);

}  // namespace rtuscope::infer
