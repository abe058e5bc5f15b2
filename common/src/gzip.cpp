// gzip of whole buffers (see the header), over zlib.
#include "pl/common/gzip.hpp"

#include <zlib.h>

namespace pl {

std::string gzip(std::string_view in, int level) {
  z_stream z{};
  if (deflateInit2(&z, level, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) throw Error("zlib: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(in.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  const std::size_t written = out.size() - z.avail_out;
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate failed");
  out.resize(written);
  return out;
}

std::string gunzip(std::string_view in, std::size_t limit) {
  z_stream z{};
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) throw Error("zlib: inflateInit2 failed");
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  std::string out;
  char buf[65536];
  for (;;) {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof buf;
    const int rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof buf - z.avail_out);
    if (rc == Z_STREAM_END) break;
    const bool stalled = rc == Z_BUF_ERROR || (rc == Z_OK && z.avail_in == 0 && z.avail_out != 0);
    if ((rc != Z_OK && rc != Z_BUF_ERROR) || stalled || out.size() > limit) {
      inflateEnd(&z);
      if (out.size() > limit) throw GzipTooLarge("gzip: inflates to more than " + std::to_string(limit) + " bytes");
      throw Error(stalled ? "gzip: the stream ends before its end" : "gzip: not a gzip stream");
    }
  }
  inflateEnd(&z);
  if (out.size() > limit) throw GzipTooLarge("gzip: inflates to more than " + std::to_string(limit) + " bytes");
  return out;
}

}  // namespace pl
