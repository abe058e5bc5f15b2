#include "access_log.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <cmath>
#include <mutex>
#include <random>

#include <nlohmann/json.hpp>

#include "pl/common/text.hpp"

namespace pl::server {

// gmtime_r: access-log lines are made on every server thread at once (gmtime's buffer is shared).
std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// UTC ISO 8601 with milliseconds, as the store writes timestamps: for JSON log lines.
std::string utc_now_ms() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const long ms = static_cast<long>(std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof(out), "%s.%03ldZ", buf, ms);
  return out;
}

// RFC 9110's IMF-fixdate, for the Date header of every response: formatted once a second per
// thread (strftime per response was 1 % of a server answering small queries).
std::string http_date() {
  thread_local std::time_t last = -1;
  thread_local std::string text;
  std::time_t t = std::time(nullptr);
  if (t != last) {
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[40];
    std::strftime(buf, sizeof(buf), "%a, %d %b %Y %H:%M:%S GMT", &tm);
    text = buf;
    last = t;
  }
  return text;
}

// Request ids: a random prefix per process and a counter ("9f3c01a2-42"), in the access log, the
// X-Request-Id header and the log line of an internal error.
std::string next_request_id() {
  static const std::uint32_t prefix = std::random_device{}();
  static std::atomic<std::uint64_t> counter{0};
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%08x-%llu", prefix, static_cast<unsigned long long>(++counter));
  return buf;
}

void write_access_line(bool json, const std::string& request_id, const std::string& remote, const std::string& method,
                       const std::string& target, int status, std::size_t bytes, double seconds) {
  static std::mutex log_mutex;
  std::string line;
  if (json) {
    nlohmann::json j = {{"time", utc_now_ms()}, {"level", "info"},       {"msg", "request"},
                        {"request_id", request_id}, {"remote", remote}, {"method", printable(method, 32)},
                        {"target", printable(target)}, {"status", status}, {"bytes", bytes},
                        {"ms", std::round(seconds * 1e6) / 1e3}};
    line = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  } else {
    char tail[96];
    std::snprintf(tail, sizeof(tail), "\" %d %zu %.3fms\n", status, bytes, seconds * 1000.0);
    line = utc_now() + " " + remote + " " + request_id + " \"" + printable(method, 32) + " " + printable(target) + tail;
  }
  std::lock_guard<std::mutex> lock(log_mutex);
  std::fputs(line.c_str(), stdout);
  std::fflush(stdout);
}

}  // namespace pl::server
