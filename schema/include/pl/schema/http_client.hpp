// A small blocking HTTP/1.1 client with a keep-alive connection (Boost.Beast, and OpenSSL for
// HTTPS), for talking to pl-server: pl-map push, the vehicle's tile client and the tests. Part of
// pl_schema so that map tools use it without the vehicle library.
//
// https:// is the normal case: the server's certificate must chain to the configured CA (or the
// system's CAs) and name the host; TLS 1.2 at least. Plain http:// sends maps and bearer tokens in
// clear, so it is refused unless the host is this machine (a loopback address or "localhost":
// nothing crosses a network) or HttpOptions::insecure_http says otherwise.
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

// The read buffer an answer is read through. Beast reads a socket into a flat buffer's free capacity
// (512 bytes at least), and a buffer the parser empties as it goes never grows: a 36 KB tile then
// took 73 recvmsg(2) calls (strace of pl-fleet). Reserved once per connection, an answer comes in
// reads of up to this many bytes.
inline constexpr std::size_t kHttpReadBuffer = std::size_t{64} << 10;

struct HttpOptions {
  static constexpr std::size_t kDefaultMaxBody = std::size_t{64} << 20;
  double timeout_s = 10.0;  // each step: connecting (with the TLS handshake), sending, the answer
  // An answer with a body over this (default: 64 MiB, the largest tile the server takes) or headers
  // over 8 KiB is refused as an error, never held in memory.
  std::size_t max_body_bytes = kDefaultMaxBody;
  std::string ca_file;         // https: PEM file of the CA certificates to trust; empty: the system's
  bool insecure_http = false;  // allow plain http:// to hosts other than this machine
};

class HttpClient {
 public:
  // base: "https://HOST:PORT" or "http://HOST:PORT" (an optional trailing path is ignored; the port
  // defaults to 443 and 80). Throws pl::Error when malformed, when plain HTTP is not allowed (see
  // above), or when ca_file cannot be read.
  HttpClient(const std::string& base, const HttpOptions& options);
  explicit HttpClient(const std::string& base, double timeout_s = 10.0, std::size_t max_body_bytes = kDefaultMaxBody);
  static constexpr std::size_t kDefaultMaxBody = HttpOptions::kDefaultMaxBody;
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
  bool tls() const { return tls_; }

 private:
  struct Impl;
  template <class Stream>
  HttpResponse exchange(Stream& stream, const std::string& method, const std::string& target, const std::string& body,
                        const std::map<std::string, std::string>& headers);
  void connect();
  void disconnect();
  std::string origin() const;  // "https://HOST:PORT", for messages

  std::unique_ptr<Impl> impl_;
  std::string host_, port_;
  bool tls_ = false;
  HttpOptions options_;
};

// Whether `host` names this machine: "localhost", an IPv4 address in 127.0.0.0/8, or ::1.
bool is_loopback_host(const std::string& host);

// "a b/c" -> "a%20b%2Fc" for query values and path segments.
std::string url_encode(const std::string& text);

}  // namespace pl::api
