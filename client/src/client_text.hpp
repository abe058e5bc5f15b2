// How the tile client writes numbers, durations and tile keys into URLs and status messages.
// Private to pl_client.
#pragma once

#include <cstdio>
#include <string>

#include "pl/common/tile_key.hpp"

namespace pl::client {

// Doubles in URLs: exact round trip, so the server tests the very disc the client reasons about.
inline std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

inline std::string seconds(double s) {  // "0.2 s"
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f s", s);
  return buf;
}

inline std::string key_name(const TileKey& k) { return std::to_string(k.tx) + "/" + std::to_string(k.ty); }

}  // namespace pl::client
