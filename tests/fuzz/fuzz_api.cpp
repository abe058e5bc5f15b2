// Fuzz target: the HTTP API as Api::handle (the code pl-server runs for every parsed request)
// sees it. The input is lines: method, target, Authorization, If-None-Match, Accept-Encoding,
// then the body (any bytes). An Accept-Encoding line "content-encoding: X" sets the body's
// Content-Encoding instead (vehicles send their change reports gzipped). See api_env.hpp for the store and the checks on every answer.
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

#include "api_env.hpp"

namespace {

// The next line of `in` (without its '\n'); the rest stays in `in`.
std::string take_line(std::string_view& in) {
  auto nl = in.find('\n');
  std::string line(in.substr(0, nl));
  in = nl == std::string_view::npos ? std::string_view() : in.substr(nl + 1);
  return line;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view in(reinterpret_cast<const char*>(data), size);
  pl::server::ApiRequest req;
  req.method = take_line(in);
  req.target = take_line(in);
  req.authorization = take_line(in);
  req.if_none_match = take_line(in);
  req.accept_encoding = take_line(in);
  const std::string ce = "content-encoding: ";
  if (req.accept_encoding.rfind(ce, 0) == 0) req.content_encoding = std::exchange(req.accept_encoding, "").substr(ce.size());
  req.body = std::string(in);
  req.request_id = "fuzz";
  // Tokens by name, so that mutations reach the roles' code: "@read", "@report", "@upload", "@admin".
  if (req.authorization == "@read") req.authorization = std::string("Bearer ") + pl::fuzz::kReadToken;
  if (req.authorization == "@report") req.authorization = std::string("Bearer ") + pl::fuzz::kReportToken;
  if (req.authorization == "@upload") req.authorization = std::string("Bearer ") + pl::fuzz::kUploadToken;
  if (req.authorization == "@admin") req.authorization = std::string("Bearer ") + pl::fuzz::kAdminToken;
  pl::fuzz::handle_checked(req);
  return 0;
}
