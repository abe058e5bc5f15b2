// A vehicle's route: a street grid laid over the map's extent, driven with a random turn at each
// crossing (never straight back, except at a dead end).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <random>
#include <vector>

namespace pl::fleet {

class Route {
 public:
  // Streets `block` metres apart over extent (min x, min y, max x, max y), at least two each way and
  // inset from the edges; the route starts at a random crossing and runs at least `length` metres.
  Route(const double extent[4], double block, double length, std::mt19937_64& rng);

  Eigen::Vector2d start() const { return pts_.front(); }
  // The point `s` metres along (monotone calls: a cursor).
  Eigen::Vector2d at(double s);

 private:
  std::vector<Eigen::Vector2d> pts_;
  std::vector<double> cum_;
  std::size_t cursor_ = 0;
};

}  // namespace pl::fleet
