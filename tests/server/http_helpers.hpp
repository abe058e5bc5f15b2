// What the server tests send and check over HTTP: a bearer token header, an answer's JSON body, and
// an error answer with its status and words.
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "pl/schema/http_client.hpp"

namespace pl::test {

inline std::map<std::string, std::string> bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

inline nlohmann::json body_json(const pl::api::HttpResponse& r) { return nlohmann::json::parse(r.body); }

// An error answer: the status, in the body too, and an error text containing `words`.
inline void expect_error(const pl::api::HttpResponse& r, int status, const std::string& words) {
  EXPECT_EQ(r.status, status) << r.body;
  nlohmann::json j = nlohmann::json::parse(r.body, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.body;
  EXPECT_EQ(j["status"], status);
  EXPECT_NE(j["error"].get<std::string>().find(words), std::string::npos) << r.body;
}

}  // namespace pl::test
