// Fuzz target: what the vehicle's tile client reads from a server (or from anything between the
// server and the vehicle): the HTTP answer itself under the client's limits, and the manifest (with
// its extent, and the list of maps), ROI
// JSON, error bodies, tile bytes and places in it. The first byte says which; the rest is the
// answer (for places: the ETag, a newline, the bytes). Also a signed manifest (verified against the
// seeds' fleet key) and a manifest's text alone; a current-version statement (verified against the
// seeds' fleet key, at a fixed clock) and its text alone.
#include <boost/asio/buffer.hpp>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "beast_feed.hpp"
#include "http_response.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/signed_current.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "seeds.hpp"
#include "wire.hpp"

namespace wire = pl::client::wire;

namespace {

void manifest(std::string_view body, std::optional<long long> pin) {
  try {
    auto m = wire::parse_manifest(body, "town", pin);
    if (!(m.tile_size > 0 && std::isfinite(m.tile_size)) || m.version < 1 || !std::isfinite(m.origin.lat_deg)) std::abort();
  } catch (const wire::WireError&) {
  }
  // The same body as the manifest's extent (a hint: never throws) and as the list of maps.
  if (const auto e = wire::parse_manifest_extent(body, pin.value_or(1))) {
    if (!(e->min_x <= e->max_x && e->min_y <= e->max_y) || !std::isfinite(e->distance(0, 0)) || e->distance(e->min_x, e->max_y) != 0) std::abort();
  }
  try {
    for (const auto& name : wire::parse_map_names(body))
      if (!wire::valid_map_name(name)) std::abort();
  } catch (const wire::WireError&) {
  }
}

void roi(std::string_view body) {
  try {
    for (const auto& t : wire::parse_roi(body, 1, 20.0))
      if (!wire::is_hash(t.hash) || t.points < 0) std::abort();
  } catch (const wire::WireError&) {
  }
}

void tile(std::string_view bytes, const std::string& hash) {
  try {
    auto cloud = wire::verified_tile(bytes, hash);
    for (const auto& p : cloud.points)
      if (!p.allFinite()) std::abort();
  } catch (const wire::WireError&) {
  } catch (const pl::Error&) {
  }
}

// The fleet key of the seeds (seeds_http.cpp signs with it).
const std::vector<std::string>& fleet() {
  static const std::vector<std::string> keys{pl::signing::SigningKey::from_seed(pl::fuzz::kFleetSeed).public_key()};
  return keys;
}

// A signed manifest as the tile client takes it (with fleet keys): what passes verified, is the
// map's and version's it was asked for, and is canonical.
void signed_manifest(std::string_view body) {
  try {
    const auto sm = wire::verified_manifest(body, fleet(), "town", 1);
    if (sm.manifest.map != "town" || sm.manifest.version != 1 || sm.public_key != fleet()[0]) std::abort();
    const std::string_view line = body.substr(sm.text.size());
    if (pl::signing::manifest_text(sm.manifest) != sm.text || line.substr(0, 18) != "signature ed25519 ") std::abort();
  } catch (const wire::WireError&) {
  }
}

// A manifest's text alone: what parses writes back byte for byte.
void manifest_text(std::string_view body) {
  try {
    const auto m = pl::signing::parse_manifest_text(body);
    if (pl::signing::manifest_text(m) != body) std::abort();
    for (std::size_t i = 1; i < m.tiles.size(); ++i)
      if (!(m.tiles[i - 1].key < m.tiles[i].key)) std::abort();
  } catch (const pl::signing::ManifestError&) {
  }
}

// A current-version statement as the tile client takes it (with timestamp keys; the seeds sign with
// the fleet key): what passes verified, is town's, is canonical and valid at the clock given.
void signed_current(std::string_view body) {
  constexpr std::int64_t kNow = 1'800'000'000;
  try {
    const auto c = wire::verified_current(body, fleet(), "town", kNow);
    if (c.map != "town" || c.version < 1 || c.expires <= c.issued || c.issued > kNow + wire::kClockSkewS ||
        c.expires < kNow - wire::kClockSkewS)
      std::abort();
    const std::string text = pl::signing::current_text(c);
    if (body.substr(0, text.size()) != text || body.substr(text.size(), 18) != "signature ed25519 ") std::abort();
  } catch (const wire::WireError&) {
  }
}

// A statement's text alone: what parses writes back byte for byte.
void current_text(std::string_view body) {
  try {
    if (pl::signing::current_text(pl::signing::parse_current_text(body)) != body) std::abort();
  } catch (const pl::signing::ManifestError&) {
  }
}

void places(std::string_view in) {
  const auto nl = in.find('\n');
  const std::string_view etag = nl == std::string_view::npos ? std::string_view() : in.substr(0, nl);
  const std::string_view bytes = nl == std::string_view::npos ? in : in.substr(nl + 1);
  try {
    wire::check_places(bytes, etag);
    if (bytes.empty()) std::abort();
    std::string_view named = etag.rfind("W/", 0) == 0 ? etag.substr(2) : etag;
    if (named.size() == 66 && named.front() == '"' && named.back() == '"' && wire::is_hash(named.substr(1, 64)) &&
        pl::store::content_hash(bytes) != named.substr(1, 64))
      std::abort();  // accepted bytes that do not match the hash their ETag names
  } catch (const wire::WireError&) {
  }
}

// An HTTP answer as HttpClient reads it (64 MiB body limit; the fuzzer's inputs are far smaller, so
// a smaller limit is used to reach the limit's code), then its body as the client would use it.
void http_answer(std::string_view in) {
  constexpr std::size_t kLimit = 4096;
  pl::api::ResponseParser parser;
  pl::api::limit_response_parser(parser, kLimit);
  boost::beast::error_code ec;
  // As HttpClient reads: the header on its own, the declared length checked, then the rest eagerly.
  std::size_t used = pl::fuzz::feed(parser, in, true, ec);
  if (!ec && !parser.is_header_done()) {
    if (!parser.got_some()) return;
    parser.put_eof(ec);
  }
  if (ec) return;  // HttpClient throws pl::Error with ec's message: the tile client backs off
  pl::api::admit_response_body(parser, kLimit, ec);
  if (ec) return;
  parser.eager(true);
  pl::fuzz::feed(parser, in.substr(used), false, ec);
  if (!ec && !parser.is_done()) parser.put_eof(ec);
  if (ec) return;
  pl::api::HttpResponse res = pl::api::to_http_response(parser.release());
  if (res.body.size() > kLimit) std::abort();
  if (res.status == 200) {
    roi(res.body);
    manifest(res.body, std::nullopt);
  } else {
    wire::error_text(res.body);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view body(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 11) {
    case 0: manifest(body, std::nullopt); break;
    case 1: manifest(body, 3); break;
    case 2: roi(body); break;
    case 3: {
      std::string text = wire::error_text(body);
      if (text.size() > 3 * 500) std::abort();
      break;
    }
    case 4: tile(body, pl::store::content_hash(body)); break;  // what the store holds, decoded
    case 5: http_answer(body); break;
    case 6: places(body); break;
    case 7: signed_manifest(body); break;
    case 8: manifest_text(body); break;
    case 9: signed_current(body); break;
    case 10: current_text(body); break;
  }
  return 0;
}
