// A place descriptor for loop proposals when the trajectory estimate has drifted too far for a search
// by position: a polar grid around the sensor (rings of range x sectors of azimuth) holding the
// height of the highest point in each bin, in the manner of Scan Context. Two scans of one place
// taken with different headings give the same grid shifted by whole sectors, so the distance is the
// best over all shifts and the shift gives the heading difference. The ring key (mean height of each
// ring) does not depend on the heading: it ranks candidates before the full comparison.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace pl::registration {

struct PlaceDescriptorConfig {
  int rings = 20;
  int sectors = 60;
  double max_range_m = 80.0;
  double height_offset_m = 2.0;  // added to z (sensor frame) so that the ground sits above zero
};

struct PlaceDescriptor {
  int rings = 0, sectors = 0;
  std::vector<float> cells;     // rings x sectors, row-major by ring; 0 = empty bin
  std::vector<float> ring_key;  // mean bin value of each ring
};

// The descriptor of a scan (points in the sensor frame, x forward, z up).
PlaceDescriptor make_place_descriptor(const std::vector<Eigen::Vector3f>& points, const PlaceDescriptorConfig& cfg = {});

struct DescriptorMatch {
  double distance = 1.0;  // mean (1 - cosine) over the sectors occupied in both, at the best shift: 0 = same
  double yaw_rad = 0.0;   // heading of `a`'s sensor relative to `b`'s: a point at azimuth phi in b is at
                          // phi - yaw_rad in a
};

// The best sector shift between two descriptors of the same size. A pair with too few sectors
// occupied in both (a quarter) has distance 1.
DescriptorMatch compare_descriptors(const PlaceDescriptor& a, const PlaceDescriptor& b);

// Squared Euclidean distance between ring keys.
double ring_key_distance(const PlaceDescriptor& a, const PlaceDescriptor& b);

}  // namespace pl::registration
