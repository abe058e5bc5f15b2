#include "http_request.hpp"

#include <nlohmann/json.hpp>

#include "pl/common/text.hpp"

namespace pl::server {

namespace http = boost::beast::http;

void limit_parser(RequestParser& parser, std::size_t header_limit) {
  parser.header_limit(static_cast<std::uint32_t>(header_limit));
  parser.body_limit(64u << 20);
}

int admit_body(RequestParser& parser) {
  const auto& req = parser.get();
  const std::size_t limit = Api::body_limit(std::string(req.method_string()), std::string(req.target()));
  const auto length = parser.content_length();
  if (length && *length > limit) return 413;
  parser.body_limit(limit);
  return 0;
}

ReadFailure read_failure(const boost::beast::error_code& ec) {
  if (ec == http::error::header_limit) return {431, false, "request headers too large"};
  if (ec == http::error::body_limit) return {413, true, "the body is larger than this route accepts"};
  if (ec == http::error::bad_method || ec == http::error::bad_target || ec == http::error::bad_version ||
      ec == http::error::bad_field || ec == http::error::bad_value || ec == http::error::bad_content_length ||
      ec == http::error::bad_transfer_encoding || ec == http::error::bad_chunk || ec == http::error::bad_chunk_extension ||
      ec == http::error::bad_line_ending || ec == http::error::bad_obs_fold || ec == http::error::bad_reason)
    return {400, false, "malformed HTTP request: " + ec.message()};
  return {0, false, {}};  // end of stream, timeout, reset: nothing to answer
}

ApiResponse rejection(int status, const std::string& message) {
  ApiResponse r;
  r.status = status;
  r.body = nlohmann::json{{"error", valid_utf8(message)}, {"status", status}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  r.route = "other";
  return r;
}

ApiRequest to_api_request(HttpRequest&& req, std::string request_id) {
  ApiRequest ar;
  ar.method = std::string(req.method_string());
  ar.target = std::string(req.target());
  ar.body = std::move(req.body());
  ar.authorization = std::string(req[http::field::authorization]);
  ar.if_none_match = std::string(req[http::field::if_none_match]);
  ar.accept_encoding = std::string(req[http::field::accept_encoding]);
  ar.content_encoding = std::string(req[http::field::content_encoding]);
  ar.request_id = std::move(request_id);
  return ar;
}

}  // namespace pl::server
