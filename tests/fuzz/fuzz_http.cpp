// Fuzz target: the bytes of a connection as pl-server reads them: Beast's request parser with the
// server's limits (header limit, per-route body limit decided once the header is in), the server's
// answers to requests it cannot read, then each parsed request (pipelined ones too) through
// Api::handle. See api_env.hpp for the store and the checks on every answer.
#include <boost/asio/buffer.hpp>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "api_env.hpp"
#include "beast_feed.hpp"
#include "http_request.hpp"

namespace http = boost::beast::http;

namespace {

constexpr std::size_t kHeaderLimit = 8 * 1024;  // ServerConfig::header_limit's default


}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view in(reinterpret_cast<const char*>(data), size);
  for (int requests = 0; !in.empty() && requests < 8; ++requests) {
    pl::server::RequestParser parser;
    pl::server::limit_parser(parser, kHeaderLimit);
    boost::beast::error_code ec;
    std::size_t used = pl::fuzz::feed(parser, in, true, ec);
    // At the end of the bytes, as Beast's read does: end of stream before any byte, else put_eof.
    if (!ec && !parser.is_header_done()) {
      if (!parser.got_some()) return 0;
      parser.put_eof(ec);
    }
    if (ec) {
      pl::server::ReadFailure f = pl::server::read_failure(ec);
      if (f.status != 0 && f.status != 400 && f.status != 413 && f.status != 431) std::abort();
      if (f.status) pl::server::rejection(f.status, f.message);
      return 0;  // the server answers (or closes) and ends the connection
    }
    if (int status = pl::server::admit_body(parser)) {
      if (status != 413) std::abort();
      return 0;
    }
    parser.eager(true);
    used += pl::fuzz::feed(parser, in.substr(used), false, ec);
    if (!ec && !parser.is_done()) parser.put_eof(ec);  // the header is in: got_some() holds
    if (ec) {
      pl::server::read_failure(ec);
      return 0;
    }
    in = in.substr(used);
    bool keep = parser.get().keep_alive();
    pl::server::ApiRequest req = pl::server::to_api_request(parser.release(), "fuzz");
    pl::fuzz::handle_checked(req);
    if (!keep) return 0;
  }
  return 0;
}
