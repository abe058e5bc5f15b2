// A vehicle's one kept-alive HTTP/1.1 connection to the server, plain or TLS: it connects when there
// is none, sends one GET at a time and reads the answer, each step within the request timeout.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <functional>
#include <optional>
#include <string>

#include "shared.hpp"

namespace pl::fleet {

class VehicleConnection {
 public:
  using Strand = boost::asio::strand<boost::asio::io_context::executor_type>;
  using Answer = boost::beast::http::response<boost::beast::http::string_body>;
  // Called on the strand when the answer has been read (no error) or a step failed; it holds what
  // must stay alive until then (the vehicle). Never called after stop().
  using Done = std::function<void(const boost::beast::error_code&)>;

  VehicleConnection(const Strand& strand, Shared& sh);

  // GET target (with the bearer token, if any) on the open connection, or on a new one.
  void get(const std::string& target, Done done);
  // Whether the last get() opened its connection (an open one the server has since closed fails on first use).
  bool fresh() const { return fresh_; }
  // The answer of the last get() that succeeded.
  Answer take_answer();
  // Closes the connection; the next get() opens another.
  void disconnect();
  // Closes the connection for good.
  void stop();

 private:
  using TcpStream = boost::beast::tcp_stream;
  TcpStream& tcp();  // the TCP stream under the connection (the TLS stream's, with https)
  void close_socket();
  void write(Done done);
  void read(Done done);

  Shared& sh_;
  Strand strand_;
  std::optional<TcpStream> plain_;                           // http://
  std::optional<boost::beast::ssl_stream<TcpStream>> tls_;  // https://
  bool connected_ = false, fresh_ = false, stopped_ = false;
  boost::beast::http::request<boost::beast::http::empty_body> req_;
  std::optional<boost::beast::http::response_parser<boost::beast::http::string_body>> parser_;
  boost::beast::flat_buffer buffer_;
};

}  // namespace pl::fleet
