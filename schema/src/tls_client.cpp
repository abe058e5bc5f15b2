#include "pl/schema/detail/tls_client.hpp"

#include <openssl/ssl.h>

#include "pl/common/error.hpp"

namespace pl::detail {

boost::asio::ssl::context tls_client_context(const std::string& ca_file) {
  boost::asio::ssl::context tls(boost::asio::ssl::context::tls_client);
  SSL_CTX_set_min_proto_version(tls.native_handle(), TLS1_2_VERSION);
  boost::system::error_code ec;
  if (ca_file.empty())
    tls.set_default_verify_paths(ec);
  else
    tls.load_verify_file(ca_file, ec);
  if (ec)
    throw Error((ca_file.empty() ? std::string("the system's CA certificates") : "CA file " + ca_file) + ": cannot be loaded (" +
                ec.message() + "): it must be a readable PEM file of CA certificates");
  tls.set_verify_mode(boost::asio::ssl::verify_peer);
  return tls;
}

}  // namespace pl::detail
