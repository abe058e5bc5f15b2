// The TLS context of every HTTPS client of the map service (the HTTP client, pl-fleet's vehicles):
// TLS 1.2 at least, the server's chain checked against a CA file or the system's CAs. The host name
// is checked per connection, where the host is known. Not a stable API (as detail/sqlite.hpp).
#pragma once

#include <boost/asio/ssl/context.hpp>

#include <string>

namespace pl::detail {

// `ca_file` empty: the system's CA certificates. Throws pl::Error naming the file when it cannot be loaded.
boost::asio::ssl::context tls_client_context(const std::string& ca_file);

}  // namespace pl::detail
