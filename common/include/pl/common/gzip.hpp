// gzip (RFC 1952) of whole buffers, for HTTP bodies: the map service's answers and the change
// reports vehicles send. Inflating is bounded: a small body must not become a large one.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "pl/common/error.hpp"

namespace pl {

// zlib's level: 1 (fastest, for answers made per request) to 9 (smallest, for what waits on a disk).
std::string gzip(std::string_view in, int level = 1);

// Thrown by gunzip for a body that inflates to more than its limit (told apart from a body that is
// not gzip: the first is too large, the second malformed).
struct GzipTooLarge : Error {
  using Error::Error;
};

// The bytes a whole gzip stream inflates to (bytes after its end are ignored). Throws GzipTooLarge
// beyond `limit` bytes, pl::Error for bytes that are not a whole gzip stream.
std::string gunzip(std::string_view in, std::size_t limit);

}  // namespace pl
