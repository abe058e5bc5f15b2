#include "pl/schema/http_client.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>

#include "http_response.hpp"
#include "pl/common/error.hpp"

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace pl::api {

std::string HttpResponse::header(const std::string& name) const {
  auto it = headers.find(name);
  return it == headers.end() ? std::string() : it->second;
}

// Runs one asynchronous operation on the client's own io_context until it completes. Beast's stream
// timer (expires_after) only applies to asynchronous operations: blocking calls never time out.
template <class Start>
void run_one(net::io_context& ioc, Start start) {
  beast::error_code result = net::error::would_block;
  start([&result](beast::error_code ec, auto&&...) { result = ec; });
  ioc.restart();
  ioc.run();
  if (result) throw beast::system_error(result);
}

struct HttpClient::Impl {
  net::io_context ioc;
  beast::tcp_stream stream{ioc};
  beast::flat_buffer buffer;
  bool connected = false;
};

void limit_response_parser(ResponseParser& parser, std::size_t max_body_bytes) {
  parser.header_limit(8 * 1024);
  parser.body_limit(max_body_bytes);
}

void admit_response_body(const ResponseParser& parser, std::size_t max_body_bytes, beast::error_code& ec) {
  const auto length = parser.content_length();
  ec = length && *length > max_body_bytes ? beast::error_code(http::error::body_limit) : beast::error_code();
}

HttpResponse to_http_response(http::response<http::string_body>&& res) {
  HttpResponse out;
  out.status = static_cast<int>(res.result_int());
  out.body = std::move(res.body());
  for (const auto& f : res) {
    std::string name(f.name_string());
    for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    out.headers[name] = std::string(f.value());
  }
  return out;
}

HttpClient::HttpClient(const std::string& base, double timeout_s, std::size_t max_body_bytes)
    : impl_(std::make_unique<Impl>()), timeout_s_(timeout_s), max_body_(max_body_bytes) {
  std::string rest = base;
  if (rest.rfind("http://", 0) == 0)
    rest = rest.substr(7);
  else if (rest.find("://") != std::string::npos)
    throw Error("server URL " + base + ": only http:// is supported (put TLS in front with a reverse proxy)");
  rest = rest.substr(0, rest.find('/'));
  auto colon = rest.rfind(':');
  if (rest.empty() || colon == std::string::npos || colon + 1 == rest.size())
    throw Error("server URL " + base + ": expected http://HOST:PORT");
  host_ = rest.substr(0, colon);
  port_ = rest.substr(colon + 1);
}

HttpClient::~HttpClient() {
  beast::error_code ec;
  impl_->stream.socket().shutdown(tcp::socket::shutdown_both, ec);
}

HttpResponse HttpClient::request(const std::string& method, const std::string& target, const std::string& body,
                                 const std::map<std::string, std::string>& headers) {
  auto timeout = std::chrono::milliseconds(static_cast<long>(timeout_s_ * 1000));
  for (int attempt = 0; attempt < 2; ++attempt) {
    bool fresh = !impl_->connected;
    try {
      if (!impl_->connected) {
        tcp::resolver resolver(impl_->ioc);
        auto endpoints = resolver.resolve(host_, port_);
        impl_->stream.expires_after(timeout);
        run_one(impl_->ioc, [&](auto done) { impl_->stream.async_connect(endpoints, done); });
        impl_->connected = true;
      }
      http::request<http::string_body> req{http::string_to_verb(method), target, 11};
      req.set(http::field::host, host_ + ":" + port_);
      req.set(http::field::user_agent, "pointlocalization");
      req.keep_alive(true);
      for (const auto& [k, v] : headers) req.set(k, v);
      req.body() = body;
      req.prepare_payload();
      impl_->stream.expires_after(timeout);
      run_one(impl_->ioc, [&](auto done) { http::async_write(impl_->stream, req, done); });
      ResponseParser parser;
      limit_response_parser(parser, max_body_);
      if (req.method() == http::verb::head) parser.skip(true);  // Content-Length, but no body follows
      run_one(impl_->ioc, [&](auto done) { http::async_read_header(impl_->stream, impl_->buffer, parser, done); });
      beast::error_code admitted;
      admit_response_body(parser, max_body_, admitted);
      if (admitted) throw beast::system_error(admitted);
      if (!parser.is_done())
        run_one(impl_->ioc, [&](auto done) { http::async_read(impl_->stream, impl_->buffer, parser, done); });
      const bool keep_alive = parser.get().keep_alive();
      HttpResponse out = to_http_response(parser.release());
      if (!keep_alive) {
        beast::error_code ec;
        impl_->stream.socket().shutdown(tcp::socket::shutdown_both, ec);
        impl_->stream.close();
        impl_->connected = false;
      }
      return out;
    } catch (const std::exception& e) {
      impl_->stream.close();
      impl_->connected = false;
      impl_->buffer.clear();
      // A kept-alive connection the server has since closed fails on first use: retry once, fresh.
      if (fresh || attempt == 1) throw Error("http://" + host_ + ":" + port_ + target + ": " + e.what());
    }
  }
  throw Error("http://" + host_ + ":" + port_ + target + ": no answer");
}

std::string url_encode(const std::string& text) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

}  // namespace pl::api
