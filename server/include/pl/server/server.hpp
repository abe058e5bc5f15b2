// pl-server's network side: an HTTP/1.1 server (Boost.Beast) with keep-alive, limits on headers,
// bodies, idle and read time and connections, one access-log line per request, and a graceful stop.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pl/server/api.hpp"

namespace pl::server {

struct ServerConfig {
  ApiConfig api;
  std::string host = "127.0.0.1";  // an address (127.0.0.1, ::1, 0.0.0.0) or a name: every address it resolves to
  std::uint16_t port = 8080;  // 0: any free port (the one chosen is printed)
  int threads = 2;
  std::size_t header_limit = 8 * 1024;
  double read_timeout_s = 10.0;  // to receive a whole request once it has started
  double idle_timeout_s = 30.0;  // between requests on a kept-alive connection
  double drain_timeout_s = 10.0; // on SIGTERM: how long in-flight requests may take
  long max_connections = 1024;
  bool access_log = true;
};

// HOST:PORT (pl-server --listen) into cfg.host and cfg.port, HOST an IPv4 address, a name, or an IPv6
// address in brackets ([::1]:8080). Throws pl::Error saying what --listen takes otherwise.
void parse_listen(const std::string& listen, ServerConfig& cfg);

class Server {
 public:
  explicit Server(ServerConfig cfg);
  ~Server();
  std::uint16_t port() const;  // the bound port
  std::vector<std::string> addresses() const;  // "127.0.0.1:8080", "[::1]:8080": where it listens
  // Serves until SIGTERM/SIGINT (or stop()): then stops accepting, lets in-flight requests finish
  // within the drain timeout, and returns.
  void run();
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::server
