// The tile client's counters and last problem (the TileClientStatus fields its parts report), written
// by the background thread's parts as things happen and read by TileClient::status(). Its mutex is
// a leaf: taken last, nothing is locked while it is held. Private to pl_client.
#pragma once

#include <cstddef>
#include <mutex>
#include <string>

#include "pl/client/tile_client.hpp"

namespace pl::client {

// What an answer refused was: a refusal stands (is last_error again after unrelated requests
// succeed) until what it refused is had another way: a version adopted, a current-version
// statement verified, a tile fetched, places fetched.
enum class Refused { manifest, current, tile, places };

class ClientStatus {
 public:
  // The last problem, naming what to do (cleared by the next successful request, back to a standing
  // refusal if there is one).
  void problem(const std::string& message) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.last_error = message;
  }
  void extent(const std::optional<MapExtent>& e) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.extent = e;
  }
  void request_retried() {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.retries;
  }
  void request_succeeded() {
    std::lock_guard<std::mutex> lock(mu_);
    st_.online = true;
    st_.last_error = standing();
  }
  void request_failed(const std::string& message) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.online = false;
    ++st_.failures;
    st_.last_error = message;
  }
  void cache_entry_dropped(const std::string& message) {  // a damaged disk cache entry
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.corrupt;
    st_.last_error = message;
  }
  // An answer refused (bytes not matching their hash, a signature not verifying, an older version
  // named current): counted, and `message` stands until what was refused is had another way.
  void refused(Refused what, const std::string& message) {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.rejected;
    refusal_[static_cast<int>(what)] = message;
    st_.last_error = message;
  }
  // An answer refused once, said until the next successful request (a server naming an older
  // version as current: the newer one is used, and the server asked again when next it is).
  void refused(const std::string& message) {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.rejected;
    st_.last_error = message;
  }
  void version_adopted() { settled(Refused::manifest); }
  void places_fetched() { settled(Refused::places); }
  // A fresh current-version statement verified: the version it names, until when (Unix seconds).
  void current_confirmed(long long version, long long until) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.confirmed_version = version;
    st_.confirmed_until = until;
    settle_locked(Refused::current);
  }
  void tile_fetched() {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.fetched;
    settle_locked(Refused::tile);
  }
  void tile_from_disk() {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.from_disk;
  }
  void tiles_evicted(std::size_t n) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.evicted += n;
  }

  // The counters, online and last_error (the other fields are the caller's to fill in).
  TileClientStatus snapshot() const {
    std::lock_guard<std::mutex> lock(mu_);
    return st_;
  }

 private:
  void settled(Refused what) {
    std::lock_guard<std::mutex> lock(mu_);
    settle_locked(what);
  }
  void settle_locked(Refused what) {
    std::string& r = refusal_[static_cast<int>(what)];
    if (r.empty()) return;
    if (st_.last_error.compare(0, r.size(), r) == 0) st_.last_error = std::string();  // (with a failed request's "retrying in")
    r.clear();
    if (st_.last_error.empty()) st_.last_error = standing();
  }
  std::string standing() const {  // the first standing refusal (a version's before a tile's), or none
    for (const auto& r : refusal_)
      if (!r.empty()) return r;
    return std::string();
  }

  mutable std::mutex mu_;
  TileClientStatus st_;
  std::string refusal_[4];  // by Refused
};

}  // namespace pl::client
