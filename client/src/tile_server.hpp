// The tile client's conversation with pl-server (schema/openapi.yaml): one kept-alive HTTP/1.1
// connection (HttpClient) with the read token, the manifest, ROI and blob requests, every answer
// checked by wire:: before it is used, and the backoff after failures (and, apart, the one-off
// request of a version's places). A failed request is counted
// and described in the ClientStatus (saying what to do and when the retry is), starts the backoff
// and throws RequestFailed. TileServer is used by the background thread only. Private to pl_client.
#pragma once

#include <functional>
#include <map>
#include <utility>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "backoff.hpp"
#include "client_status.hpp"
#include "fetch_plan.hpp"
#include "pl/schema/http_client.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/client/tile_cache.hpp"
#include "pl/client/tile_client.hpp"
#include "pl/common/tile_codec.hpp"

namespace pl::client {

// A failed request, already counted and described in the status: unwinds to the client's loop.
struct RequestFailed {};

// Tile bytes that match their hash but do not decode (a tile the store holds broken): not a failed
// request. what() is the decoder's message.
struct UndecodableTile : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class TileServer {
 public:
  // Throws pl::Error for a malformed server URL. Keeps references to cfg and status.
  TileServer(const TileClientConfig& cfg, ClientStatus& status);

  // Whether a request may go now (no backoff running), and when the running backoff ends.
  bool may_ask() const { return backoff_.allowed(); }
  Backoff::Clock::time_point retry_at() const { return backoff_.until(); }
  // The HTTP status of the last answered request (0: none answered).
  int last_status() const { return last_status_; }

  // GET /v1/maps/{map}: the manifest of `pin` (else of the map's current version).
  CachedManifest manifest(std::optional<long long> pin);
  // GET /v1/maps/{map}/versions/{v}/manifest: the version's signed manifest, verified against
  // `trusted` (wire::verified_manifest), and the body as it came (for the disk cache). One that
  // does not verify is counted as rejected and failed.
  // After a refusal the next tries ask by other URLs (".../manifest?refused=N", N = 1, 2, ...):
  // other entries of any HTTP cache on the way, so that one poisoned entry does not keep the
  // vehicle off the map, while the vehicles that all met it share each next entry.
  std::pair<signing::SignedManifest, std::string> signed_manifest(long long version, const std::vector<std::string>& trusted);
  // GET /v1/maps/{map}/current: the map's current version as a fresh statement signed with one of
  // `trusted` (wire::verified_current at the system clock), reported as confirmed. One that does
  // not verify, is another map's or has expired is counted, stands in the status as refused, and
  // fails; the next tries ask by other URLs (".../current?refused=N"), as for signed manifests.
  // `own` (a running client's rechecks): a refusal starts that backoff instead of the one all
  // requests wait for, so that tiles keep coming while a statement is held back.
  long long current(const std::vector<std::string>& trusted, Backoff* own = nullptr);
  // GET /v1/maps/{map}/roi: the tiles the server lists for the query's disc in `version`.
  std::vector<CachedTile> roi(const RoiQuery& q, long long version, double tile_size);

  struct Blob {
    std::string bytes;  // the Draco bytes, matching the hash
    TileCloud cloud;    // decoded
  };
  // GET /v1/blobs/{hash} for the tile `t` of `version` (by_key: GET
  // /v1/maps/{map}/versions/{v}/tiles/{tx}/{ty}, another URL and so another entry of any HTTP
  // cache on the way): its bytes checked against the hash, then decoded. Throws RequestFailed for
  // bytes that do not match (counted as rejected: last_rejected() is then true), UndecodableTile
  // for bytes that match but do not decode.
  Blob blob(const CachedTile& t, long long version, bool by_key = false);
  // Whether the last request failed because its answer was refused: bytes that did not match their
  // hash, a manifest whose signature did not verify.
  bool last_rejected() const { return last_rejected_; }

 private:
  api::HttpResponse get(const std::string& target, const std::string& about, const std::function<std::string()>& hint_404);
  std::string maps_on_server();
  [[noreturn]] void failed(const std::string& message);
  // An answer refused: counted, standing in the status as `what`, and failed (on `own`, a backoff of
  // its own, when given: then not as a failed request, which would hold back every other).
  // other_url_next: the first refusal of an object, whose next try goes by another URL (another
  // cache entry): a cache or the network altered it, the server is not failing, so nothing backs
  // off and the other URL is asked at once. A second refusal backs off as any failure.
  [[noreturn]] void refused(Refused what, const std::string& message, Backoff* own = nullptr, bool other_url_next = false);
  void succeeded();
  std::string pinned_hint(long long version) const;

  const TileClientConfig& cfg_;
  ClientStatus& status_;
  api::HttpClient http_;
  std::map<std::string, std::string> headers_;
  Backoff backoff_;
  int last_status_ = 0;
  bool last_rejected_ = false;
  int manifest_refusals_ = 0;  // signed manifests refused so far
  int current_refusals_ = 0;   // current-version statements refused so far
};

// GET /v1/maps/{map}/versions/{v}/places for TileClient::places: on the caller's thread, over a
// connection of its own (the background thread's is not shared) that waits at most timeout_s for
// each step (connecting; sending and the answer). Returns the bytes, checked (wire::check_places),
// or nothing when the server answers 404 (the version has no places, or the server does not have
// the version). Throws pl::Error saying what failed and what to do. No backoff, no status counts.
std::optional<std::string> fetch_places(const TileClientConfig& cfg, long long version, double timeout_s);

}  // namespace pl::client
