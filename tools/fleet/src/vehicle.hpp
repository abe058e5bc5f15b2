// A virtual vehicle: a small state machine on the fleet's io_context, with its own strand, connection
// (vehicle_connection.hpp), scan timer and backoff. The tile client's own planning and answer checks
// decide what it asks for and what it accepts; it keeps the clock, drives its route and counts.
#pragma once

#include <Eigen/Core>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/error.hpp>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "backoff.hpp"
#include "fetch_plan.hpp"
#include "pl/client/tile_cache.hpp"
#include "pl/common/tile_key.hpp"
#include "pl/fleet/fleet.hpp"
#include "route.hpp"
#include "shared.hpp"
#include "tile_index.hpp"
#include "vehicle_connection.hpp"

namespace pl::fleet {

// What a vehicle's cache answers were, by kind of request (X-Cache).
struct CacheTally {
  CacheCounts tiles, roi, manifests;
};

class Vehicle : public std::enable_shared_from_this<Vehicle> {
 public:
  Vehicle(boost::asio::io_context& ioc, Shared& sh, int id);

  // Starts its clock: the first tick at its start time.
  void go();

  VehicleReport report();
  const std::vector<float>& tile_ms() const { return tile_ms_; }
  const std::vector<float>& roi_ms() const { return roi_ms_; }
  const CacheTally& cache() const { return cache_; }
  const std::map<std::string, std::size_t>& failure_kinds() const { return failure_kinds_; }

 private:
  enum class Phase { Waiting, Starting, Driving, Stopped };
  enum class Kind { Manifest, Current, Signed, Roi, Tile };
  // A tile in memory: its hash and what it counts against the memory bound.
  struct Held {
    std::string hash;
    std::size_t size = 0;
  };
  using Present = std::unordered_map<TileKey, Held, TileKeyHash>;

  static std::mt19937_64 seeded(unsigned long long seed, int id);

  // ---- the clock and driving
  void on_tick(const boost::beast::error_code& ec);
  void stop();
  void scan(Clock::time_point now);
  bool start_complete() const;

  // ---- what to ask next
  void pump();
  const client::FetchPlan& current_plan(Clock::time_point now);
  bool anything_to_do(Clock::time_point now);
  client::TileIndex& index_w();
  bool held_back(const std::string& hash, Clock::time_point now);
  void arm_wake(Clock::time_point at);

  // ---- one request and its outcome
  void send(Kind kind, std::string target);
  void exchange();
  void transport_failed(const boost::beast::error_code& ec);
  void failed(const std::string& why, bool now = false);
  void done();
  void rejected();
  void answered();

  // ---- the answers
  void become_ready(const client::CachedManifest& m);
  void on_manifest(const std::string& body);
  void on_current(const std::string& body);
  void on_signed(const std::string& body);
  void on_roi(const std::string& body);
  void on_tile(const std::string& body);

  // ---- the memory bound
  void drop(Present::iterator it);
  void make_room();

  Shared& sh_;
  boost::asio::strand<boost::asio::io_context::executor_type> strand_;
  VehicleConnection conn_;
  boost::asio::steady_timer tick_, wake_;
  std::mt19937_64 rng_;
  client::Backoff backoff_;
  VehicleReport rep_;
  std::optional<Route> route_;
  Phase phase_ = Phase::Waiting;
  Clock::time_point started_, driving_since_, last_scan_, sent_at_;
  Eigen::Vector2d pos_ = Eigen::Vector2d::Zero(), focus_now_ = Eigen::Vector2d::Zero(), focus_ahead_ = Eigen::Vector2d::Zero();
  TileGrid truth_grid_{sh_.tile_size};

  bool ready_ = false;
  std::optional<long long> version_;  // with fleet keys: the version whose signed manifest is asked for
  int manifest_refusals_ = 0;         // signed manifests refused (the next is asked with ?refused=N)
  int current_refusals_ = 0;          // current-version statements refused (likewise)
  client::CachedManifest manifest_;
  std::optional<TileGrid> grid_;
  // What the vehicle knows of the version. A complete index from a signed manifest is shared with
  // every vehicle that checked the same bytes; index_w() makes the vehicle's own copy to change.
  std::shared_ptr<client::TileIndex> own_ = std::make_shared<client::TileIndex>();
  std::shared_ptr<const client::TileIndex> index_ = own_;
  std::uint64_t index_gen_ = 0;  // bumped at each change of the index
  std::optional<client::FetchPlan> plan_;
  Eigen::Vector2d planned_now_ = Eigen::Vector2d::Zero(), planned_ahead_ = Eigen::Vector2d::Zero();
  std::uint64_t planned_index_ = 0;
  std::size_t plan_cursor_ = 0;  // in plan_->wants: where the next look for a tile to fetch starts
  Present present_;
  std::size_t memory_ = 0;
  std::set<std::string> by_key_;
  std::map<std::string, Clock::time_point> held_;

  bool busy_ = false, stopping_ = false, resent_ = false, wake_armed_ = false;
  Kind kind_ = Kind::Manifest;
  std::string target_;
  std::map<std::string, std::size_t> failure_kinds_;
  client::Disc roi_disc_{Eigen::Vector2d::Zero(), 0};
  client::CachedTile asked_;
  bool asked_by_key_ = false;
  std::vector<float> tile_ms_, roi_ms_;
  CacheTally cache_;
};

}  // namespace pl::fleet
