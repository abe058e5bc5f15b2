// What pl-server writes about each request: the access log's lines, the Date header, request ids.
// Safe on every server thread at once. Private to pl_server.
#pragma once

#include <cstddef>
#include <string>

namespace pl::server {

std::string utc_now();     // UTC ISO 8601 to the second, for access-log lines
std::string utc_now_ms();  // UTC ISO 8601 with milliseconds, as the store writes timestamps: for JSON log lines
std::string http_date();   // RFC 9110's IMF-fixdate, for the Date header of every response
// Request ids: a random prefix per process and a counter ("9f3c01a2-42"), in the access log, the
// X-Request-Id header and the log line of an internal error.
std::string next_request_id();

// One access-log line to stdout, written whole under a lock the threads share: JSON with `json`,
// else "TIME REMOTE ID "METHOD TARGET" STATUS BYTES MSms".
void write_access_line(bool json, const std::string& request_id, const std::string& remote, const std::string& method,
                       const std::string& target, int status, std::size_t bytes, double seconds);

}  // namespace pl::server
