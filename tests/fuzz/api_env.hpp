// The map service as the API fuzz targets see it: a real SQLite map store (a map "town" with a
// published version of three tiles and places, two drives' change reports against it, a staged
// version, a token per role), made once, and for
// every input a fresh copy of it under a real Api, so that no input sees what an earlier one wrote.
// Checks every answer: a status the API documents, JSON that parses (UTF-8 included), gzip that
// inflates; a 500 (an exception nobody expected) is a finding.
#pragma once

#include <string>

#include "pl/server/api.hpp"

namespace pl::fuzz {

// Tokens in the store, by role.
constexpr const char* kReadToken = "read-token-0123456789";
constexpr const char* kReportToken = "report-token-0123456789";
constexpr const char* kUploadToken = "upload-token-0123456789";
constexpr const char* kAdminToken = "admin-token-0123456789";
// The places of version 1 (and of staged version 2, its copy).
constexpr const char* kTownPlaces = "places of town version 1";

// Answers the request from a fresh copy of the store (aborts on an answer that breaks the rules above).
server::ApiResponse handle_checked(const server::ApiRequest& req);

// The bytes of a real tile of map "town" at key (tx, ty) (20 m tiles), for seeds.
std::string town_tile(int tx, int ty);

}  // namespace pl::fuzz
