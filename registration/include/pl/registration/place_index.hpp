// Place recognition over a map: the descriptor of a scan taken at each of the map's places (scans
// of the drive that built it, every few metres), stored with the map version, and the places whose
// descriptors look most like a new scan's, each with the pose it suggests. Registration verifies
// the proposals: a descriptor only says where to look.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "pl/registration/place_descriptor.hpp"

namespace pl::registration {

struct Place {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // of the sensor, map frame
  double yaw = 0;                                      // of the sensor's x axis from the map's x axis, radians
  PlaceDescriptor descriptor;
};

struct PlaceProposal {
  // The scan's sensor pose the place suggests: the place's position, level, at the place's heading
  // turned by the descriptor's shift.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double distance = 1.0;  // of the descriptors (0 same .. 1)
  std::size_t place = 0;  // index into places()
};

class PlaceIndex {
 public:
  PlaceIndex() = default;
  // Throws pl::Error when a descriptor is not of the config's size or a pose is not finite.
  PlaceIndex(const PlaceDescriptorConfig& cfg, std::vector<Place> places);

  const PlaceDescriptorConfig& config() const { return cfg_; }
  const std::vector<Place>& places() const { return places_; }
  bool empty() const { return places_.empty(); }

  // The bytes stored with a map version (little-endian, heights in 0.1 m steps): the same places
  // give the same bytes.
  std::string encode() const;
  // Reads encode()'s bytes; throws pl::Error "SOURCE: not a places file|... at byte N: ..." naming
  // what is wrong and how to get a good file.
  static PlaceIndex decode(std::string_view bytes, const std::string& source);

  // The `count` places whose descriptors are nearest `scan`'s, best first, among those within
  // `radius_m` of `center` (a radius <= 0: all). Ring keys choose the candidates compared in full
  // (a tenth of the places, at least 50).
  std::vector<PlaceProposal> propose(const PlaceDescriptor& scan, std::size_t count, const Eigen::Vector2d& center = {0, 0},
                                     double radius_m = 0) const;

 private:
  PlaceDescriptorConfig cfg_;
  std::vector<Place> places_;
};

// The sensor's heading (yaw of its x axis) in a pose.
double heading_of(const Eigen::Isometry3d& pose);
// The rotation that levels a sensor at `pose`: its roll and pitch, its heading taken out.
Eigen::Matrix3d levelling(const Eigen::Isometry3d& pose);
// The descriptor of a scan (sensor frame) taken at `pose`, its points turned level: as places are
// made and as scans are compared with them.
PlaceDescriptor levelled_descriptor(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& pose,
                                    const PlaceDescriptorConfig& cfg);

}  // namespace pl::registration
