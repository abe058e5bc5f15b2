// The server's counters and latency histograms (GET /metrics).
#include <cstdio>
#include <sstream>

#include "pl/server/api.hpp"

namespace pl::server {

// ---------------------------------------------------------------------------------------------
// Metrics

constexpr const char* Metrics::kRoutes[];
constexpr int Metrics::kStatuses[];
constexpr double Metrics::kBuckets[];

void Metrics::observe(const std::string& route, int status, double seconds, std::size_t bytes) {
  std::size_t r = kNRoutes - 1, s = kNStatuses - 1, b = 0;
  for (std::size_t i = 0; i < kNRoutes; ++i)
    if (route == kRoutes[i]) r = i;
  for (std::size_t i = 0; i + 1 < kNStatuses; ++i)
    if (status == kStatuses[i]) s = i;
  while (b + 1 < kNBuckets && seconds > kBuckets[b]) ++b;
  requests_[r][s].fetch_add(1, std::memory_order_relaxed);
  buckets_[b].fetch_add(1, std::memory_order_relaxed);
  latency_ns_.fetch_add(static_cast<std::uint64_t>(seconds * 1e9), std::memory_order_relaxed);
  latency_count_.fetch_add(1, std::memory_order_relaxed);
  bytes_.fetch_add(bytes, std::memory_order_relaxed);
}

std::string Metrics::render(std::int64_t database_bytes) const {
  std::ostringstream o;
  o << "# HELP pl_requests_total HTTP requests by route and status.\n# TYPE pl_requests_total counter\n";
  for (std::size_t r = 0; r < kNRoutes; ++r)
    for (std::size_t s = 0; s < kNStatuses; ++s) {
      std::uint64_t n = requests_[r][s].load(std::memory_order_relaxed);
      if (n == 0) continue;
      o << "pl_requests_total{route=\"" << kRoutes[r] << "\",status=\"" << (kStatuses[s] ? std::to_string(kStatuses[s]) : "other")
        << "\"} " << n << "\n";
    }
  o << "# HELP pl_request_duration_seconds Time from a parsed request to its response.\n"
       "# TYPE pl_request_duration_seconds histogram\n";
  std::uint64_t cum = 0;
  for (std::size_t b = 0; b + 1 < kNBuckets; ++b) {
    cum += buckets_[b].load(std::memory_order_relaxed);
    o << "pl_request_duration_seconds_bucket{le=\"" << kBuckets[b] << "\"} " << cum << "\n";
  }
  cum += buckets_[kNBuckets - 1].load(std::memory_order_relaxed);
  o << "pl_request_duration_seconds_bucket{le=\"+Inf\"} " << cum << "\n";
  o << "pl_request_duration_seconds_sum " << static_cast<double>(latency_ns_.load()) * 1e-9 << "\n";
  o << "pl_request_duration_seconds_count " << latency_count_.load() << "\n";
  o << "# HELP pl_bytes_served_total Response body bytes sent.\n# TYPE pl_bytes_served_total counter\n";
  o << "pl_bytes_served_total " << bytes_.load() << "\n";
  o << "# HELP pl_open_connections Connections open now.\n# TYPE pl_open_connections gauge\n";
  o << "pl_open_connections " << open_connections.load() << "\n";
  o << "# HELP pl_database_bytes Size of the map store.\n# TYPE pl_database_bytes gauge\n";
  o << "pl_database_bytes " << database_bytes << "\n";
  return o.str();
}

}  // namespace pl::server
