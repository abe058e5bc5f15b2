// What the vehicles share: the settings, the server's address and TLS context, the truth about the
// version, the signed manifests already checked, the run's clock and its progress counters.
#pragma once

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <chrono>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/fleet/fleet.hpp"
#include "tile_index.hpp"

namespace pl::fleet {

using Clock = std::chrono::steady_clock;

inline double secs(Clock::duration d) { return std::chrono::duration<double>(d).count(); }
inline Clock::duration dur(double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); }

struct Shared {
  FleetOptions o;
  boost::asio::ip::tcp::resolver::results_type endpoints;
  std::string host_header;
  std::string host;                                   // for SNI and the certificate's name check (https)
  std::optional<boost::asio::ssl::context> tls;       // https only
  std::vector<std::string> trusted;
  std::vector<std::string> current_keys;  // timestamp keys: "current" only from a fresh signed statement
  std::unordered_map<TileKey, std::string, TileKeyHash> truth;  // the version's tiles (key -> hash), for stalls
  // Signed manifests already checked, by the content hash of their bytes and the version asked for:
  // the index they give (null: refused). Every vehicle still fetches the bytes and hashes them; the
  // check and the index of a body seen before are the same function of the same bytes, so they are
  // made once and shared (2,000 vehicles parsing a 51,456-tile manifest each took 192 s of the load
  // generator's one core, and as many indexes took gigabytes).
  struct Checked {
    std::shared_ptr<const client::TileIndex> index;  // null: refused
    client::CachedManifest manifest;
  };
  std::mutex checked_mutex;
  std::map<std::pair<std::string, long long>, Checked> checked;
  double tile_size = 0;
  double extent[4] = {0, 0, 0, 0};       // of the version's tiles: min x, min y, max x, max y
  Clock::time_point start, end;
  std::atomic<int> ready{0}, driving{0};
  std::atomic<std::size_t> scans{0}, stalled{0}, tile_requests{0}, roi_queries{0}, failures{0}, rejected{0};
};

}  // namespace pl::fleet
