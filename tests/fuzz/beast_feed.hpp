// Feeding a fuzz input to a Beast parser the way Beast's reads do: put() until the parser stops
// needing more bytes (the header only, or the whole message), or fails.
#pragma once

#include <boost/asio/buffer.hpp>
#include <boost/beast/http.hpp>
#include <string_view>

namespace pl::fuzz {

// Returns the bytes used; `ec` is the parser's error, need_more cleared.
template <class Parser>
std::size_t feed(Parser& p, std::string_view in, bool header_only, boost::beast::error_code& ec) {
  std::size_t used = 0;
  while (!ec && used < in.size() && !(header_only ? p.is_header_done() : p.is_done())) {
    std::size_t n = p.put(boost::asio::buffer(in.data() + used, in.size() - used), ec);
    used += n;
    if (ec == boost::beast::http::error::need_more) {
      ec = {};
      if (n == 0) break;  // needs bytes the input does not have
    }
  }
  return used;
}

}  // namespace pl::fuzz
