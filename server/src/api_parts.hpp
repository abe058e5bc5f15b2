// The parts of a request and an answer that the API's handlers share: errors that become answers,
// JSON answers, gzip, the target's path segments and query, and the checked numbers in them.
// Private to pl_server.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pl/common/gzip.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/schema/store.hpp"
#include "pl/server/api.hpp"

namespace pl::server::api_parts {

using nlohmann::json;

// Thrown by a handler, answered as a JSON error with this status (and extra headers).
struct HttpError {
  int status;
  std::string message;
  std::vector<std::pair<std::string, std::string>> headers;
};

// Throws HttpError; the message echoes what the client sent, so it is made valid UTF-8 first.
[[noreturn]] void fail(int status, const std::string& message);
ApiResponse json_response(int status, const json& j, const std::string& route);
// The answer marked ApiResponse::revalidate (its ETag: the body's hash).
ApiResponse revalidated(ApiResponse r);
// The ETag of an answer to `target` fixed by a published or retired version of a map: 32 hex digits
// of a 128-bit FNV-1a over the map's id and creation time, the version and the target. Not a
// cryptographic hash: two bodies of one URL need only differ in their tags, never resist an attacker
// (an ETag is the server's own word, and the cache's key is the URL).
std::string answer_tag(const store::MapInfo& map, std::int64_t version, std::string_view target);

// The methods of each resource, for 405 answers and OPTIONS.
constexpr const char* kReadOnly = "GET, HEAD, OPTIONS";
constexpr const char* kPostOnly = "POST, OPTIONS";
[[noreturn]] void method_not_allowed(const std::string& method, const std::string& route, const char* allow);

// Does an Accept-Encoding header accept gzip (RFC 9110 12.5.3 q-values)?
bool accepts_gzip(std::string_view header);  // (the gzip itself: pl/common/gzip.hpp)

std::string url_decode(std::string_view s);
struct Target {
  std::vector<std::string> segments;
  std::map<std::string, std::string> query;
};
Target parse_target(const std::string& target);
// A query parameter as a number (fail(400) when it is not one, or missing and required).
double query_number(const Target& t, const std::string& key, bool required, double fallback);
std::int64_t parse_version(const std::string& s);     // fail(400) unless a whole number >= 1
std::int32_t parse_tile_index(const std::string& s);  // fail(400) unless a whole int32
std::string tile_url(const std::string& map, std::int64_t v, const TileKey& k);

// The fleet's change reports and the updates made from them (api_reports.cpp). `by` is who the
// store's log names; `publish` publishes a staged version as POST .../publish does.
ApiResponse post_report(store::Store& db, const ApiRequest& req, const std::string& map, const std::string& by);
ApiResponse list_reports(store::Store& db, const Target& t, const std::string& map);
ApiResponse changes(store::Store& db, const Target& t, const std::string& map);
ApiResponse update(store::Store& db, const ApiRequest& req, const std::string& map, const std::string& by,
                   const std::function<void(std::int64_t)>& publish);

}  // namespace pl::server::api_parts
