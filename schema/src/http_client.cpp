#include "pl/schema/http_client.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/ssl.hpp>
#include <chrono>
#include <optional>

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include "http_response.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/detail/tls_client.hpp"

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
  std::optional<net::ssl::context> tls;  // https only
  // One of the two, made anew for each connection (an SSL stream is not reused after it closed).
  std::unique_ptr<beast::tcp_stream> plain;
  std::unique_ptr<beast::ssl_stream<beast::tcp_stream>> secure;
  beast::flat_buffer buffer;
  bool connected = false;

  beast::tcp_stream& tcp() { return secure ? beast::get_lowest_layer(*secure) : *plain; }
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

bool is_loopback_host(const std::string& host) {
  if (host == "localhost" || host == "::1" || host == "[::1]") return true;
  beast::error_code ec;
  const auto addr = net::ip::make_address_v4(host, ec);
  return !ec && addr.is_loopback();
}

HttpClient::HttpClient(const std::string& base, double timeout_s, std::size_t max_body_bytes)
    : HttpClient(base, [&] {
        HttpOptions o;
        o.timeout_s = timeout_s;
        o.max_body_bytes = max_body_bytes;
        return o;
      }()) {}

HttpClient::HttpClient(const std::string& base, const HttpOptions& options)
    : impl_(std::make_unique<Impl>()), options_(options) {
  impl_->buffer.reserve(kHttpReadBuffer);
  std::string rest;
  if (base.rfind("https://", 0) == 0) {
    tls_ = true;
    rest = base.substr(8);
  } else if (base.rfind("http://", 0) == 0) {
    rest = base.substr(7);
  } else {
    throw Error("server URL " + base + ": expected https://HOST[:PORT] (or http:// to this machine)");
  }
  rest = rest.substr(0, rest.find('/'));
  const auto colon = rest.rfind(':');
  const bool bracketed = !rest.empty() && rest.front() == '[';  // [IPv6]:PORT
  if (colon == std::string::npos || (bracketed && rest.back() == ']')) {
    host_ = rest;
    port_ = tls_ ? "443" : "80";
  } else {
    host_ = rest.substr(0, colon);
    port_ = rest.substr(colon + 1);
  }
  if (host_.empty() || port_.empty() || port_.find_first_not_of("0123456789") != std::string::npos)
    throw Error("server URL " + base + ": expected https://HOST[:PORT]");
  if (!tls_ && !options_.insecure_http && !is_loopback_host(host_))
    throw Error("server URL " + base + ": plain HTTP to another machine sends the map and the token in clear: use https:// (with --ca-file naming the fleet's CA), or pass --insecure-http to allow it");
  if (tls_) impl_->tls.emplace(detail::tls_client_context(options_.ca_file));
}

HttpClient::~HttpClient() { disconnect(); }

std::string HttpClient::origin() const { return std::string(tls_ ? "https://" : "http://") + host_ + ":" + port_; }

void HttpClient::disconnect() {
  if (!impl_->plain && !impl_->secure) return;
  beast::error_code ec;
  impl_->tcp().socket().shutdown(tcp::socket::shutdown_both, ec);
  impl_->tcp().close();
  impl_->plain.reset();
  impl_->secure.reset();
  impl_->connected = false;
  impl_->buffer.clear();
}

void HttpClient::connect() {
  const auto timeout = std::chrono::milliseconds(static_cast<long>(options_.timeout_s * 1000));
  // An IPv6 literal is written in brackets in the URL and the Host header, without them elsewhere.
  const bool bracketed = host_.size() > 2 && host_.front() == '[' && host_.back() == ']';
  const std::string name = bracketed ? host_.substr(1, host_.size() - 2) : host_;
  tcp::resolver resolver(impl_->ioc);
  const auto endpoints = resolver.resolve(name, port_);
  if (tls_) {
    impl_->secure = std::make_unique<beast::ssl_stream<beast::tcp_stream>>(impl_->ioc, *impl_->tls);
    // SNI, so that a server with several names shows the right certificate; then the check that the
    // certificate names this host (RFC 6125), on top of its chain to a trusted CA.
    // (SNI carries names only, not address literals.)
    beast::error_code literal;
    net::ip::make_address(name, literal);
    if (literal && !SSL_set_tlsext_host_name(impl_->secure->native_handle(), name.c_str()))
      throw beast::system_error(beast::error_code(static_cast<int>(::ERR_get_error()), net::error::get_ssl_category()));
    impl_->secure->set_verify_callback(net::ssl::host_name_verification(name));
  } else {
    impl_->plain = std::make_unique<beast::tcp_stream>(impl_->ioc);
  }
  impl_->tcp().expires_after(timeout);
  run_one(impl_->ioc, [&](auto done) { impl_->tcp().async_connect(endpoints, done); });
  if (tls_) {
    impl_->tcp().expires_after(timeout);
    try {
      run_one(impl_->ioc, [&](auto done) { impl_->secure->async_handshake(net::ssl::stream_base::client, done); });
    } catch (const std::exception& e) {
      const long verify = SSL_get_verify_result(impl_->secure->native_handle());
      if (verify != X509_V_OK)
        throw Error(std::string("the server's certificate is not trusted (") + X509_verify_cert_error_string(verify) +
                    "): it must be signed by the CA in --ca-file (or the system's) and name " + host_);
      throw;
    }
  }
  impl_->connected = true;
}

template <class Stream>
HttpResponse HttpClient::exchange(Stream& stream, const std::string& method, const std::string& target, const std::string& body,
                                  const std::map<std::string, std::string>& headers) {
  const auto timeout = std::chrono::milliseconds(static_cast<long>(options_.timeout_s * 1000));
  http::request<http::string_body> req{http::string_to_verb(method), target, 11};
  req.set(http::field::host, host_ + ":" + port_);
  req.set(http::field::user_agent, "pointlocalization");
  req.keep_alive(true);
  for (const auto& [k, v] : headers) req.set(k, v);
  req.body() = body;
  req.prepare_payload();
  impl_->tcp().expires_after(timeout);
  run_one(impl_->ioc, [&](auto done) { http::async_write(stream, req, done); });
  ResponseParser parser;
  limit_response_parser(parser, options_.max_body_bytes);
  if (req.method() == http::verb::head) parser.skip(true);  // Content-Length, but no body follows
  run_one(impl_->ioc, [&](auto done) { http::async_read_header(stream, impl_->buffer, parser, done); });
  beast::error_code admitted;
  admit_response_body(parser, options_.max_body_bytes, admitted);
  if (admitted) throw beast::system_error(admitted);
  if (!parser.is_done()) run_one(impl_->ioc, [&](auto done) { http::async_read(stream, impl_->buffer, parser, done); });
  const bool keep_alive = parser.get().keep_alive();
  HttpResponse out = to_http_response(parser.release());
  if (!keep_alive) disconnect();
  return out;
}

HttpResponse HttpClient::request(const std::string& method, const std::string& target, const std::string& body,
                                 const std::map<std::string, std::string>& headers) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool fresh = !impl_->connected;
    try {
      if (!impl_->connected) connect();
      return impl_->secure ? exchange(*impl_->secure, method, target, body, headers)
                           : exchange(*impl_->plain, method, target, body, headers);
    } catch (const std::exception& e) {
      disconnect();
      // A kept-alive connection the server has since closed fails on first use: retry once, fresh.
      if (fresh || attempt == 1) throw Error(origin() + target + ": " + e.what());
    }
  }
  throw Error(origin() + target + ": no answer");
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
