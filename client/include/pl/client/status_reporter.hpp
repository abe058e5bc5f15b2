// A vehicle's position and health, told to the map service (POST /v1/maps/{map}/vehicles/{id},
// a token of the report role) so that the viewer shows the fleet live. The localizer hands each
// new state over (update(): cheap, the latest wins); a thread of its own sends the latest every
// every_s seconds, so the network never holds the localization up, and a state not sent because the
// service was out of reach is simply replaced by a newer one: nothing queues.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <memory>
#include <string>

#include "pl/client/localizer.hpp"
#include "pl/schema/http_client.hpp"

namespace pl::client {

struct StatusReporterConfig {
  std::string server;   // https://HOST[:PORT]
  std::string token;    // a token of the report role
  std::string map;      // the map the position is in (its ENU frame)
  std::string vehicle;  // the vehicle's id, as in its change reports: 1-128 of [A-Za-z0-9_.:-]
  double every_s = 1.0;
  api::HttpOptions http;
  void validate() const;  // throws pl::Error naming the field
};

class StatusReporter {
 public:
  explicit StatusReporter(StatusReporterConfig cfg);  // starts the thread; never blocks on the network
  ~StatusReporter();                                   // sends the last state once more (bounded by the timeout), stops
  StatusReporter(const StatusReporter&) = delete;
  StatusReporter& operator=(const StatusReporter&) = delete;

  // The vehicle's base in the map frame, its health, its time (seconds).
  void update(const Eigen::Isometry3d& base_in_map, Health health, double t);

  struct Stats {
    std::size_t sent = 0, failed = 0;
    std::string last_error;
  };
  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::client
