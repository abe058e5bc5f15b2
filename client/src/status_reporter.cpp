// The vehicle's position and health to the map service (see the header).
#include "pl/client/status_reporter.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "pl/common/error.hpp"
#include "pl/schema/change_report.hpp"

namespace pl::client {

namespace {

struct State {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  Health health = Health::Ok;
  double t = 0;
};

}  // namespace

void StatusReporterConfig::validate() const {
  if (server.empty()) throw Error("status reporter: server is empty (the map service's https://HOST[:PORT])");
  if (token.empty()) throw Error("status reporter: a token of the report role is needed (pl-map token-add --role report)");
  if (map.empty()) throw Error("status reporter: map is empty");
  if (!schema::valid_id(vehicle)) throw Error("status reporter: vehicle must be 1-128 of A-Z a-z 0-9 _ . : -, got \"" + vehicle + "\"");
  if (!(every_s >= 0.05 && every_s <= 3600)) throw Error("status reporter: every_s must be within 0.05..3600 s");
}

struct StatusReporter::Impl {
  StatusReporterConfig cfg;
  mutable std::mutex mu;
  std::condition_variable wake;
  std::optional<State> latest;  // not sent yet
  bool stop = false;
  Stats stats;
  std::thread thread;

  void send(const State& s, api::HttpClient& http) {
    const Eigen::Vector3d p = s.base.translation();
    const Eigen::Vector3d ahead = s.base.linear().col(0);
    const nlohmann::json body = {{"x", p.x()}, {"y", p.y()}, {"z", p.z()}, {"yaw", std::atan2(ahead.y(), ahead.x())},
                                 {"health", health_name(s.health)}, {"t", s.t}};
    std::string error;
    try {
      const auto r = http.request("POST", "/v1/maps/" + cfg.map + "/vehicles/" + cfg.vehicle, body.dump(),
                                  {{"Authorization", "Bearer " + cfg.token}, {"Content-Type", "application/json"}});
      if (r.status != 200) error = "the map service answered " + std::to_string(r.status) + ": " + r.body;
    } catch (const Error& e) {
      error = e.what();
    }
    std::lock_guard<std::mutex> lock(mu);
    if (error.empty()) {
      ++stats.sent;
    } else {
      ++stats.failed;
      stats.last_error = error;
    }
  }

  void run() {
    std::unique_ptr<api::HttpClient> http;
    const auto period = std::chrono::duration<double>(cfg.every_s);
    std::unique_lock<std::mutex> lock(mu);
    while (true) {
      wake.wait_for(lock, period, [&] { return stop; });
      std::optional<State> s = std::exchange(latest, std::nullopt);
      const bool last = stop;
      lock.unlock();
      if (s) {
        try {
          if (!http) http = std::make_unique<api::HttpClient>(cfg.server, cfg.http);
          send(*s, *http);
        } catch (const Error& e) {  // a server URL the client refuses
          std::lock_guard<std::mutex> l(mu);
          ++stats.failed;
          stats.last_error = e.what();
        }
      }
      lock.lock();
      if (last) return;
    }
  }
};

StatusReporter::StatusReporter(StatusReporterConfig cfg) : impl_(std::make_unique<Impl>()) {
  cfg.validate();
  impl_->cfg = std::move(cfg);
  Impl* m = impl_.get();
  m->thread = std::thread([m] { m->run(); });
}

StatusReporter::~StatusReporter() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->stop = true;
  }
  impl_->wake.notify_all();
  impl_->thread.join();
}

void StatusReporter::update(const Eigen::Isometry3d& base_in_map, Health health, double t) {
  if (!base_in_map.matrix().allFinite() || !std::isfinite(t)) return;  // nothing to show of a diverged pose
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->latest = State{base_in_map, health, t};
}

StatusReporter::Stats StatusReporter::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->stats;
}

}  // namespace pl::client
