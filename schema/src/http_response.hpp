// How the HTTP client reads an answer: the parser's limits and what of the message reaches the
// caller. Private to pl_schema; shared by HttpClient and the client_answers fuzz target.
#pragma once

#include <boost/beast/http.hpp>
#include <cstddef>

#include "pl/schema/http_client.hpp"

namespace pl::api {

using ResponseParser = boost::beast::http::response_parser<boost::beast::http::string_body>;

// Headers up to 8 KiB, the body up to max_body_bytes: a larger answer fails to parse (body_limit)
// before it is held in memory.
void limit_response_parser(ResponseParser& parser, std::size_t max_body_bytes);

// After the header (read on its own, not eagerly): body_limit when the declared Content-Length is
// over the parser's limit. Beast 1.74 checks this itself, but in an eager read (the header and
// body bytes in one buffer) the error is overwritten as it goes on to the body, and the string
// body then reserves the declared length: a 2 GiB Content-Length cost 2 GiB.
void admit_response_body(const ResponseParser& parser, std::size_t max_body_bytes, boost::beast::error_code& ec);

// Status, body and headers (names in lower case; a repeated header keeps its last value).
HttpResponse to_http_response(boost::beast::http::response<boost::beast::http::string_body>&& res);

}  // namespace pl::api
