// One request on a vehicle's kept-alive connection: connect (and the TLS handshake) when there is
// none, write the GET, read the answer, each step within the request timeout.
#include "vehicle_connection.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/ssl.hpp>
#include <openssl/ssl.h>
#include <utility>

#include "pl/schema/http_client.hpp"

namespace pl::fleet {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = net::ip::tcp;

namespace {
constexpr std::size_t kMaxBody = std::size_t{64} << 20;  // the largest tile the server takes
}  // namespace

VehicleConnection::VehicleConnection(const Strand& strand, Shared& sh) : sh_(sh), strand_(strand) {
  buffer_.reserve(api::kHttpReadBuffer);
  if (!sh.tls) plain_.emplace(strand_);
}

beast::tcp_stream& VehicleConnection::tcp() { return tls_ ? beast::get_lowest_layer(*tls_) : *plain_; }

void VehicleConnection::close_socket() {
  if (!plain_ && !tls_) return;
  beast::error_code ignored;
  tcp().socket().shutdown(tcp::socket::shutdown_both, ignored);
  tcp().close();
}

void VehicleConnection::get(const std::string& target, Done done) {
  req_ = {};
  req_.method(http::verb::get);
  req_.target(target);
  req_.version(11);
  req_.set(http::field::host, sh_.host_header);
  req_.set(http::field::user_agent, "pl-fleet");
  if (!sh_.o.token.empty()) req_.set(http::field::authorization, "Bearer " + sh_.o.token);
  req_.keep_alive(true);
  fresh_ = !connected_;
  if (connected_) return write(std::move(done));
  if (sh_.tls) {  // a TLS stream per connection (no operation of the last one is pending: one request at a time)
    tls_.emplace(strand_, *sh_.tls);
    beast::error_code literal;
    net::ip::make_address(sh_.host, literal);
    if (literal) SSL_set_tlsext_host_name(tls_->native_handle(), sh_.host.c_str());  // SNI carries names only
    tls_->set_verify_callback(net::ssl::host_name_verification(sh_.host));
  }
  tcp().expires_after(dur(sh_.o.timeout_s));
  tcp().async_connect(sh_.endpoints, [this, done = std::move(done)](beast::error_code ec, const tcp::endpoint&) mutable {
    if (stopped_) return;
    if (ec) return done(ec);
    if (!tls_) {
      connected_ = true;
      return write(std::move(done));
    }
    tls_->async_handshake(net::ssl::stream_base::client, [this, done = std::move(done)](beast::error_code e) mutable {
      if (stopped_) return;
      if (e) return done(e);
      connected_ = true;
      write(std::move(done));
    });
  });
}

void VehicleConnection::write(Done done) {
  tcp().expires_after(dur(sh_.o.timeout_s));
  auto written = [this, done = std::move(done)](beast::error_code ec, std::size_t) mutable {
    if (stopped_) return;
    if (ec) return done(ec);
    read(std::move(done));
  };
  if (tls_)
    http::async_write(*tls_, req_, std::move(written));
  else
    http::async_write(*plain_, req_, std::move(written));
}

void VehicleConnection::read(Done done) {
  parser_.emplace();
  parser_->body_limit(kMaxBody);
  tcp().expires_after(dur(sh_.o.timeout_s));
  auto got = [this, done = std::move(done)](beast::error_code ec, std::size_t) {
    if (stopped_) return;
    done(ec);
  };
  if (tls_)
    http::async_read(*tls_, buffer_, *parser_, std::move(got));
  else
    http::async_read(*plain_, buffer_, *parser_, std::move(got));
}

VehicleConnection::Answer VehicleConnection::take_answer() {
  Answer res = parser_->release();
  parser_.reset();
  return res;
}

void VehicleConnection::disconnect() {
  close_socket();  // (no TLS close_notify: the server sees the connection end, as when a vehicle drives off)
  buffer_.consume(buffer_.size());
  connected_ = false;
}

void VehicleConnection::stop() {
  stopped_ = true;
  close_socket();
}

}  // namespace pl::fleet
