// The server's counters and latency histograms (GET /metrics).
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>

#include "pl/server/api.hpp"

namespace pl::server {

namespace {

std::string compiler() {
#if defined(__clang__)
  return "clang " __clang_version__;
#elif defined(__GNUC__)
  return "gcc " __VERSION__;
#else
  return "unknown";
#endif
}

// The process metrics Prometheus' client libraries export under these names, from /proc/self.
void process_metrics(std::ostream& o) {
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK)), page = static_cast<double>(sysconf(_SC_PAGESIZE));
  std::ifstream stat("/proc/self/stat");
  std::string line;
  if (std::getline(stat, line)) {
    // Fields after the command name (which may hold spaces, so read from the last ')').
    std::istringstream rest(line.substr(line.rfind(')') + 2));
    std::vector<std::string> f{std::istream_iterator<std::string>(rest), std::istream_iterator<std::string>()};
    // f[0] is field 3 (state): utime 14, stime 15, starttime 22, vsize 23, rss 24.
    if (f.size() > 21) {
      const double cpu = (std::stod(f[11]) + std::stod(f[12])) / tick;
      std::ifstream uptime("/proc/uptime");
      double up = 0;
      uptime >> up;
      const double start = static_cast<double>(std::time(nullptr)) - up + std::stod(f[19]) / tick;
      o << "# HELP process_cpu_seconds_total User and system CPU time spent, seconds.\n# TYPE process_cpu_seconds_total counter\n"
        << "process_cpu_seconds_total " << cpu << "\n";
      o << "# HELP process_start_time_seconds Start time of the process since the Unix epoch, seconds.\n"
           "# TYPE process_start_time_seconds gauge\n"
        << "process_start_time_seconds " << static_cast<long long>(start) << "\n";
      o << "# HELP process_virtual_memory_bytes Virtual memory size, bytes.\n# TYPE process_virtual_memory_bytes gauge\n"
        << "process_virtual_memory_bytes " << f[20] << "\n";
      o << "# HELP process_resident_memory_bytes Resident memory size, bytes.\n# TYPE process_resident_memory_bytes gauge\n"
        << "process_resident_memory_bytes " << static_cast<long long>(std::stod(f[21]) * page) << "\n";
    }
  }
  std::size_t fds = 0;
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator("/proc/self/fd", ec); !ec && it != std::filesystem::directory_iterator();
       it.increment(ec))
    ++fds;
  o << "# HELP process_open_fds Open file descriptors.\n# TYPE process_open_fds gauge\nprocess_open_fds " << fds << "\n";
  rlimit lim{};
  if (getrlimit(RLIMIT_NOFILE, &lim) == 0)
    o << "# HELP process_max_fds Most open file descriptors allowed.\n# TYPE process_max_fds gauge\nprocess_max_fds "
      << static_cast<long long>(lim.rlim_cur) << "\n";
}

}  // namespace

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
  o << "# HELP pl_requests_in_progress Requests begun (header read) and not yet answered, this one included.\n"
       "# TYPE pl_requests_in_progress gauge\n";
  o << "pl_requests_in_progress " << requests_in_progress.load() << "\n";
  if (database_bytes >= 0) {
    o << "# HELP pl_database_bytes Size of the map store.\n# TYPE pl_database_bytes gauge\n";
    o << "pl_database_bytes " << database_bytes << "\n";
  }
  o << "# HELP pl_store_reachable Whether the map store answered the last look (1) or not (0).\n"
       "# TYPE pl_store_reachable gauge\n";
  o << "pl_store_reachable " << (database_bytes >= 0 ? 1 : 0) << "\n";
  o << "# HELP pl_build_info The build serving: version and compiler (always 1).\n# TYPE pl_build_info gauge\n";
  o << "pl_build_info{version=\"" << PL_VERSION << "\",compiler=\"" << compiler() << "\"} 1\n";
  process_metrics(o);
  return o.str();
}

}  // namespace pl::server
