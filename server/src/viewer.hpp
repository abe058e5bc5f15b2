// The map viewer's side of pl-server (viewer.cpp): the viewer's static files (GET /viewer/), a
// version's overview level, the version list, and the live vehicles (their last position and health
// in memory, and a Server-Sent Events stream of their updates). Private to pl_server: api.cpp routes
// to it, server.cpp streams the events.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "pl/schema/store.hpp"
#include "pl/server/api.hpp"

namespace pl::server {

// One client's Server-Sent Events stream: the records the vehicle hub queued for it, which the
// network side (server.cpp) takes and writes. The hub and the connection run on different threads:
// everything here is under one mutex, and `wake` (set by the connection) is called, outside it,
// whenever records were queued or the stream was closed.
class EventStream {
 public:
  // Keep-alive comment lines this often (proxies and browsers drop a silent connection), and a
  // client so slow that a write of ours is still pending at the next keep-alive loses the stream.
  static constexpr int kKeepAliveSeconds = 15;
  // Records queued and not yet taken: beyond this the client is not reading, and the stream closes.
  static constexpr std::size_t kMaxPendingBytes = 1u << 20;

  void set_wake(std::function<void()> wake);
  // Queues a whole record ("event: vehicle\ndata: {...}\n\n"). False (and the stream closed) when
  // the client has fallen kMaxPendingBytes behind; false too once closed.
  bool push(std::string_view record);
  // The records queued since the last take (empty: none).
  std::string take();
  void close();
  bool closed() const;

 private:
  void notify();
  mutable std::mutex mutex_;
  std::string pending_;
  std::function<void()> wake_;
  bool closed_ = false;
};

// The viewer's routes. Thread-safe. api.cpp checks tokens and finds the map and version, then calls
// these.
class Viewer {
 public:
  explicit Viewer(const ApiConfig& cfg);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // GET /viewer (301 to /viewer/), /viewer/ (index.html) and /viewer/FILE from the viewer's folder.
  ApiResponse file(const ApiRequest& req);
  // GET /v1/maps/{map}/versions: the map's versions, staged ones only when `staged_visible`.
  static ApiResponse versions(store::Store& db, const store::MapInfo& map, bool staged_visible);
  // GET /v1/maps/{map}/versions/{v}/overview: the version thinned to one point per coarse voxel,
  // one Draco cloud; made once per published or retired version and kept.
  ApiResponse overview(store::Store& db, const ApiRequest& req, const store::MapInfo& map, const store::VersionInfo& version);
  // POST /v1/maps/{map}/vehicles/{id}, GET /v1/maps/{map}/vehicles, GET /v1/maps/{map}/events
  // (ApiResponse::events set: the network side streams it).
  ApiResponse post_vehicle(const ApiRequest& req, const std::string& map, const std::string& id);
  ApiResponse vehicles(const std::string& map);
  ApiResponse events(const std::string& map, bool head);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::server
