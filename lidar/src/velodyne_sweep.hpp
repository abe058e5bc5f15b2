// Checked Velodyne packets -> sweeps. Each column's azimuth is unwrapped over turns (by the time
// since the previous packet and the measured rotation rate); each firing's azimuth is its column's
// plus its share of the step to the next column (by its firing time within the column); a sweep
// holds every firing from one crossing of the cut azimuth to the next, wherever the packet boundary
// falls, and its stamp is the time of its first firing.
#pragma once

#include <cstdint>
#include <vector>

#include "pl/lidar/decoder.hpp"
#include "velodyne_geometry.hpp"
#include "velodyne_model.hpp"

namespace pl::lidar {

class VelodyneSweeper {
 public:
  explicit VelodyneSweeper(const DecoderOptions& options);

  // One packet whose blocks match `layout`; `single` is the return type of single-return packets.
  // Sweeps it completes go to `out`, counted in `counts`.
  void add(const std::uint8_t* packet, const VelodyneLayout& layout, ReturnType single, std::int64_t packet_ns,
           const VelodyneGeometry& geometry, std::vector<Sweep>& out, DecodeCounts& counts);
  // The open sweeps (with points), then a fresh start.
  void finish(std::vector<Sweep>& out, DecodeCounts& counts);
  // Measured rotation, 0.01 degree per microsecond (0 until two columns were seen).
  double rate() const { return rate_; }

 private:
  struct OpenSweep {
    Sweep sweep;
    bool fired = false;
    std::int64_t first_ns = 0, earliest_ns = 0;
  };

  // Unwraps the packet's columns; false when the packet follows a gap of a second or more.
  void unwrap_columns(const std::uint8_t* packet, const VelodyneLayout& layout, std::int64_t packet_ns,
                      std::vector<Sweep>& out, DecodeCounts& counts);
  void start_at(double turned);
  void emit(OpenSweep& s, std::vector<Sweep>& out, DecodeCounts& counts);

  double min_range_m_, max_range_m_;
  double cut_ = 0;  // 0.01 degree

  // This packet's columns: azimuth, azimuth unwrapped over turns, step to the next column.
  int azimuth_[12] = {};
  double turned_[12] = {};
  float step_[12] = {};
  std::int64_t shift_ns_[12] = {};  // a column's firing time beyond the table's (after a jump)
  // The previous packet's last column.
  bool have_previous_ = false;
  int previous_azimuth_ = 0;
  double previous_turned_ = 0;
  std::int64_t previous_ns_ = 0;
  double rate_ = 0;
  double sweep_end_ = 0;  // unwrapped azimuth where the current sweep ends
  OpenSweep current_, next_;
};

}  // namespace pl::lidar
