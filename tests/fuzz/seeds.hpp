// The seed writers of make_fuzz_seeds: each seeds_*.cpp registers one function per fuzz target
// that writes that target's seeds with the project's own writers.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace pl::fuzz {

// put(name, bytes): one seed file of the target.
using PutSeed = std::function<void(const std::string& name, const std::string& bytes)>;
using SeedMaker = void (*)(const PutSeed& put);

// The private key (RFC 8032 seed, 32 bytes) the seeds' signed manifests are signed with, and that
// the client_answers target trusts.
inline constexpr std::string_view kFleetSeed = "pointlocalization fuzz fleet key";
static_assert(kFleetSeed.size() == 32);

// Registers the seed maker of a target (at static initialisation); returns true.
bool register_seeds(const char* target, SeedMaker make);

}  // namespace pl::fuzz
