// The map's current version, vouched for fresh: a short text pl-server signs when asked (GET
// /v1/maps/{map}/current) with its timestamp key, an Ed25519 key the servers hold online (not the
// fleet's publishing key, which stays offline), and an expiry the vehicle checks against its clock.
// A signed manifest proves what a version holds, not that it is the newest: without this, a cache
// or the network could keep a vehicle from learning of a newer version (a freeze) or start a new
// vehicle on an older signed one. With it, either is bounded by the statement's lifetime (the role
// The Update Framework calls "timestamp").
//
// The text, one field a line, each line ending in '\n', numbers as decimal integers:
//
//   pointlocalization-current 1
//   map NAME
//   version N                  (the map's current version when the statement was made)
//   issued UNIX_SECONDS
//   expires UNIX_SECONDS       (after issued)
//
// followed, as served, by the signature line of a signed manifest (pl/schema/signed_manifest.hpp):
//
//   signature ed25519 PUBLIC_KEY SIGNATURE
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "pl/schema/signed_manifest.hpp"

namespace pl::signing {

struct CurrentVersion {
  std::string map;
  std::int64_t version = 0;
  std::int64_t issued = 0, expires = 0;  // Unix seconds
  bool operator==(const CurrentVersion& o) const {
    return map == o.map && version == o.version && issued == o.issued && expires == o.expires;
  }
};

// The largest statement read: a valid one is under 200 bytes.
inline constexpr std::size_t kMaxCurrentBytes = 1024;

// The canonical text (the bytes that are signed). Throws pl::Error for a statement no server makes
// (an invalid map name, a version below 1, an expiry not after the issue).
std::string current_text(const CurrentVersion& c);

// Reads a statement's text (without a signature line), strictly: it must be exactly what
// current_text writes for what it says. Throws ManifestError naming the line and the problem.
CurrentVersion parse_current_text(std::string_view text);

// The text followed by its signature line by `key`: what pl-server answers.
std::string sign_current(const CurrentVersion& c, const SigningKey& key);

struct SignedCurrent {
  CurrentVersion current;
  std::string public_key;  // the key it verified against (one of the trusted)
};

// A statement as served: parsed, and its signature checked against `trusted` (public keys, 32
// bytes each). Throws ManifestError when it does not parse, carries no signature, is signed by a key
// not among the trusted, or its signature does not verify. Says nothing of its time: check_current.
SignedCurrent verify_signed_current(std::string_view body, const std::vector<std::string>& trusted);

// Whether a verified statement may be used at `now` (Unix seconds): it is `map`'s, was issued no
// later than now + skew_s and expires no earlier than now - skew_s (skew_s: how far the vehicle's
// clock and the servers' may disagree). Throws ManifestError saying which is not so and what to do.
void check_current(const CurrentVersion& c, const std::string& map, std::int64_t now, std::int64_t skew_s);

// This machine's clock in Unix seconds: the time statements are issued at and checked against.
std::int64_t unix_now();

}  // namespace pl::signing
