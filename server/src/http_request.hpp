// What pl-server does between a request's bytes and the API: how the parser is limited, what a
// request that cannot be read is answered, and what of a parsed request reaches Api::handle.
// Private to pl_server; shared by the network side (server.cpp) and the request fuzz target.
#pragma once

#include <boost/beast/core/error.hpp>
#include <boost/beast/http.hpp>
#include <cstddef>
#include <string>

#include "pl/server/api.hpp"

namespace pl::server {

using HttpRequest = boost::beast::http::request<boost::beast::http::string_body>;
using RequestParser = boost::beast::http::request_parser<boost::beast::http::string_body>;

// A fresh parser's limits: headers up to header_limit bytes; the body limit is set per route once
// the header is in (Api::body_limit), so until then no body is accepted beyond the largest route's.
void limit_parser(RequestParser& parser, std::size_t header_limit);

// After the header: the route's body limit, or the status to refuse the request with (413 when the
// declared length is over it), 0 when fine.
int admit_body(RequestParser& parser);

// A request that could not be read: the status to answer (0: nothing to answer, close), whether to
// linger (the client may still be sending a body) and the message.
struct ReadFailure {
  int status = 0;
  bool linger = false;
  std::string message;
};
ReadFailure read_failure(const boost::beast::error_code& ec);

// The JSON error answer of a refused request.
ApiResponse rejection(int status, const std::string& message);

// What Api::handle sees of a parsed request (its body is moved out).
ApiRequest to_api_request(HttpRequest&& req, std::string request_id);

}  // namespace pl::server
