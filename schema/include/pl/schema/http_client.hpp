// A small blocking HTTP/1.1 client with a keep-alive connection (Boost.Beast), for talking to
// pl-server: pl-map push, the vehicle's tile client and the tests. Part of pl_schema so that map
// tools use it without the vehicle library.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <string>

namespace pl::api {

struct HttpResponse {
  int status = 0;
  std::string body;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string header(const std::string& name) const;
};

class HttpClient {
 public:
  // base: "http://HOST:PORT" (an optional trailing path is ignored). Throws pl::Error when malformed.
  // An answer with a body over max_body_bytes (default: 64 MiB, the largest tile the server takes)
  // or headers over 8 KiB is refused as an error, never held in memory.
  explicit HttpClient(const std::string& base, double timeout_s = 10.0, std::size_t max_body_bytes = kDefaultMaxBody);
  static constexpr std::size_t kDefaultMaxBody = std::size_t{64} << 20;
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  // Sends one request on the kept-alive connection (reconnecting once if the server closed it).
  // Throws pl::Error when the server cannot be reached or does not answer within the timeout.
  HttpResponse request(const std::string& method, const std::string& target, const std::string& body = {},
                       const std::map<std::string, std::string>& headers = {});
  HttpResponse get(const std::string& target, const std::map<std::string, std::string>& headers = {}) {
    return request("GET", target, {}, headers);
  }
  const std::string& host() const { return host_; }
  const std::string& port() const { return port_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string host_, port_;
  double timeout_s_;
  std::size_t max_body_;
};

// "a b/c" -> "a%20b%2Fc" for query values and path segments.
std::string url_encode(const std::string& text);

}  // namespace pl::api
