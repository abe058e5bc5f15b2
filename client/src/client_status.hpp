// The tile client's counters and last problem (the TileClientStatus fields its parts report), written
// by the background thread's parts as things happen and read by TileClient::status(). Its mutex is
// a leaf: taken last, nothing is locked while it is held. Private to pl_client.
#pragma once

#include <cstddef>
#include <mutex>
#include <string>

#include "pl/client/tile_client.hpp"

namespace pl::client {

class ClientStatus {
 public:
  // The last problem, naming what to do (cleared by the next successful request).
  void problem(const std::string& message) {
    std::lock_guard<std::mutex> lock(mu_);
    st_.last_error = message;
  }
  void request_retried() {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.retries;
  }
  void request_succeeded() {
    std::lock_guard<std::mutex> lock(mu_);
    st_.online = true;
    st_.last_error.clear();
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
  void rejected() {  // an answer refused: bytes not matching their hash, a signature not verifying
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.rejected;
  }
  void tile_fetched() {
    std::lock_guard<std::mutex> lock(mu_);
    ++st_.fetched;
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
  mutable std::mutex mu_;
  TileClientStatus st_;
};

}  // namespace pl::client
