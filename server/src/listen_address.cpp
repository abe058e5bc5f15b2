// The address pl-server listens on, as --listen (or its config file's listen) gives it: HOST:PORT
// into ServerConfig.
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/server/server.hpp"

namespace pl::server {

void parse_listen(const std::string& listen, ServerConfig& cfg) {
  const auto colon = listen.rfind(':');
  long long port = -1;
  std::string host = colon == std::string::npos ? "" : listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  else if (host.find(':') != std::string::npos)
    host.clear();  // an IPv6 address needs its brackets
  if (host.empty() || !parse_int(listen.substr(colon + 1), port) || port < 0 || port > 65535)
    throw Error("--listen takes HOST:PORT (127.0.0.1:8080, localhost:8080, [::1]:8080, 0.0.0.0:8080), got \"" + listen + "\"");
  cfg.host = host;
  cfg.port = static_cast<std::uint16_t>(port);
}

}  // namespace pl::server
