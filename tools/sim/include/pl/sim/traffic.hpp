// Moving traffic: cars, trucks (2.5 m x 10 m) and pedestrians along the roads of the route. Some
// vehicles drive just ahead of or behind the ego vehicle in its lane, blocking much of the view;
// the rest come the other way or walk the pavements.
#pragma once

#include <cstdint>
#include <vector>

#include "pl/sim/lidar.hpp"
#include "pl/sim/trajectory.hpp"

namespace pl::sim {

struct TrafficConfig {
  int count = 0;
  std::uint64_t seed = 1;
  double truck_share = 0.3;       // of the vehicles
  double pedestrian_share = 0.3;  // of all agents
  double road_half_width = 6.0;
};

class Traffic {
 public:
  Traffic(const SimTrajectory& path, double t0, double t1, const TrafficConfig& cfg);
  // The agents' shapes at time t within `radius` of `near` (empty scene when there are none).
  Scene scene_at(double t, const Eigen::Vector3d& near, double radius) const;
  std::size_t size() const { return agents_.size(); }
  // 2-D footprint centres at time t (for the preview).
  std::vector<Eigen::Vector2f> positions_at(double t) const;

 private:
  enum class Kind : std::uint8_t { Car, Truck, Pedestrian };
  enum class Mode : std::uint8_t { Lead, Oncoming, Walk };
  struct Agent {
    Kind kind;
    Mode mode;
    double lateral;  // metres left of the path
    double s0;       // arc length at t0 (Oncoming/Walk) or gap to the ego vehicle (Lead, negative: behind)
    double speed;    // m/s along the path (negative: against the route's direction)
    double phase;    // for the lead gap's slow variation
  };
  bool place(const Agent& a, double t, Eigen::Vector2f& centre, float& yaw, float& base) const;
  const SimTrajectory& path_;
  double t0_, s_min_, s_max_;
  std::vector<Agent> agents_;
};

}  // namespace pl::sim
