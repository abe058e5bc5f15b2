// The parts of the URLs the fleet is given: the server and each origin's /metrics.
#pragma once

#include <string>

#include "pl/common/error.hpp"

namespace pl::fleet {

// "http://HOST:PORT[/path]" -> host, port, path ("" when none).
struct Url {
  std::string scheme, host, port, path;
};

// Throws pl::Error naming `what` (the setting the URL came from) when it is not a URL with a host.
inline Url parse_url(const std::string& url, const std::string& what) {
  Url u;
  const auto colon = url.find("://");
  if (colon == std::string::npos) throw Error(what + ": \"" + url + "\" is not a URL: write http://HOST:PORT");
  u.scheme = url.substr(0, colon);
  std::string rest = url.substr(colon + 3);
  const auto slash = rest.find('/');
  if (slash != std::string::npos) {
    u.path = rest.substr(slash);
    rest = rest.substr(0, slash);
  }
  const auto pc = rest.rfind(':');
  if (pc != std::string::npos && rest.find(']') == std::string::npos) {
    u.host = rest.substr(0, pc);
    u.port = rest.substr(pc + 1);
  } else {
    u.host = rest;
    u.port = u.scheme == "https" ? "443" : "80";
  }
  if (u.host.empty() || u.port.empty()) throw Error(what + ": \"" + url + "\" names no host: write http://HOST:PORT");
  return u;
}

}  // namespace pl::fleet
