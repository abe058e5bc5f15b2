// The map a scan is registered against: points with unit normals in a voxel hash, held as float32
// offsets from a double-precision anchor (so the map frame may be anywhere on Earth), made of parts
// (the tiles around a vehicle, the merged keyframes of a loop check) that enter and leave without
// rebuilding the rest.
//
// A cell belongs to the part that filled it first; cut parts along cell boundaries (tiles whose edge
// the cell divides, anchored on the tile grid) and no point is ever dropped.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <memory>
#include <vector>

namespace pl::registration {

// A map point in anchor coordinates with its unit normal.
struct MapPoint {
  Eigen::Vector3f p;
  Eigen::Vector3f n;
};

struct Neighbour {
  const MapPoint* point = nullptr;  // nullptr: nothing within the distance asked
  float dist2 = 0;
};

// The cells one query read, kept by a caller who asks again from nearly the same place (ICP's next
// iteration moves a scan point by millimetres): a query in the same block reads them again without
// a lookup in the table, whose slots are the half of a lookup's time spent waiting for memory.
// Valid only with the map it was filled from and until that map changes.
struct CellBlock {
  std::uint64_t own = ~std::uint64_t{0};  // the key of the query's own cell (none yet)
  std::uint8_t side = 0;                  // per axis, bit set: the neighbour read is the one above
  std::uint8_t looked = 0;                // per block member: looked up
  struct Span {
    const MapPoint* begin = nullptr;
    std::uint32_t count = 0;
  };
  Span cells[8];  // member m: the cell m & 1, m >> 1 & 1, m >> 2 & 1 steps towards the query's side
};

class PointMap {
 public:
  using PartId = std::uint64_t;

  // anchor: any point near where the map is used (kept exactly); cell_m > 0: the hash cell edge.
  // Nearest-neighbour search is exact within cell_m / 2 and approximate up to cell_m.
  PointMap(const Eigen::Vector3d& anchor, double cell_m);
  ~PointMap();
  PointMap(const PointMap&) = delete;
  PointMap& operator=(const PointMap&) = delete;

  // Adds a part: points in the map frame, one unit normal each. Throws pl::Error when the id is
  // already held or the sizes differ.
  void add(PartId id, const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3f>& normals);
  // Removes a part and every cell it owned; false when it was not held.
  bool remove(PartId id);
  bool contains(PartId id) const { return parts_.count(id) != 0; }

  // Nearest map point to q (anchor coordinates) within sqrt(max_dist2) (at most cell_m).
  Neighbour nearest(const Eigen::Vector3f& q, float max_dist2) const;
  // The same, reading the cells `block` holds when q lies in the same block, and keeping there what
  // it looks up. Exactly the same answer.
  Neighbour nearest(const Eigen::Vector3f& q, float max_dist2, CellBlock& block) const;
  // Brings the first points of the cells `block` holds into the cache (the second stage, for a query
  // whose block is known).
  static void prefetch_points(const CellBlock& block);
  // Brings q's own cell into the cache: called a few queries ahead, it hides most of a lookup's wait
  // for memory (the table is larger than the cache).
  void prefetch(const Eigen::Vector3f& q) const;
  // The second stage, a few queries later: q's own cell looked up (its slot now cached) and the
  // first of its points brought in.
  void prefetch_points(const Eigen::Vector3f& q) const;

  const Eigen::Vector3d& anchor() const { return anchor_; }
  double cell_m() const { return cell_; }
  std::size_t parts() const { return parts_.size(); }
  std::size_t points() const { return points_; }
  std::size_t cells() const;
  // Every point (anchor coordinates), parts in id order.
  std::vector<MapPoint> all_points() const;

 private:
  struct Part;
  struct Cells;
  double cell_;
  Eigen::Vector3d anchor_;
  std::map<PartId, std::unique_ptr<Part>> parts_;
  std::unique_ptr<Cells> cells_;
  std::size_t points_ = 0;
  std::uint64_t cell_of(const Eigen::Vector3f& q) const;  // the key of q's own cell
};

}  // namespace pl::registration
