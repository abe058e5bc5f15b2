// Recordings whose clouds other tools laid out: a time field that carries no time (the Velodyne
// layout with every time 0) is set aside and named, and a cloud with no ring field (PCL's PointXYZI)
// gets its rings from its points' order where they come laser by laser, else from their elevations
// against a sensor's beam table where they fit one, and none where they fit none.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "cdr_writer.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/mcap_writer.hpp"
#include "test_util.hpp"

namespace {

using pl::test::CdrWriter;

enum class Layout { VelodyneZeroTime, PclXyzi };
constexpr int kRings = 16, kColumns = 90, kScans = 6;

// The ring of point k of a scan written laser by laser.
int ring_of(int k) { return k / kColumns; }

// A PointCloud2 field: name, offset, datatype (2 uint8 ... 7 float32).
struct Field {
  const char* name;
  std::uint32_t offset;
  std::uint8_t type;
};

// The beams of the scans: a VLP-16's (-15 to 15 degrees by 2), or beams no sensor has.
struct Beams {
  double lowest_deg = -15, step_deg = 2;
};

// One scan of 16 rings x 90 columns, each ring one counter-clockwise turn from straight ahead, as a
// CDR PointCloud2 in `layout`; `shuffled` writes the same points in a random order.
std::string cloud(Layout layout, int scan, bool shuffled, Beams beams) {
  const bool velodyne = layout == Layout::VelodyneZeroTime;
  const std::vector<Field> fields = velodyne ? std::vector<Field>{{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7},
                                                                 {"ring", 16, 4}, {"time", 18, 7}}
                                             : std::vector<Field>{{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 16, 7}};
  const std::uint32_t step = velodyne ? 22 : 32, n = kRings * kColumns;
  std::vector<int> order(n);
  for (std::uint32_t k = 0; k < n; ++k) order[k] = static_cast<int>(k);
  if (shuffled) std::shuffle(order.begin(), order.end(), std::mt19937(7));
  std::string data(static_cast<std::size_t>(step) * n, '\0');
  for (std::uint32_t i = 0; i < n; ++i) {
    const int k = order[i], ring = ring_of(k), col = k % kColumns;
    const double az = 2 * M_PI * (col + 0.5) / kColumns, el = (beams.lowest_deg + beams.step_deg * ring) * M_PI / 180, range = 8.0 + 0.01 * col;
    const float xyz[3] = {static_cast<float>(range * std::cos(el) * std::cos(az)), static_cast<float>(range * std::cos(el) * std::sin(az)),
                          static_cast<float>(range * std::sin(el))};
    const float intensity = static_cast<float>(ring);
    char* p = data.data() + static_cast<std::size_t>(step) * i;
    std::memcpy(p, xyz, 12);
    std::memcpy(p + (velodyne ? 12 : 16), &intensity, 4);
    if (velodyne) {
      const auto r = static_cast<std::uint16_t>(ring);
      std::memcpy(p + 16, &r, 2);  // the time at 18 stays 0
    }
  }
  CdrWriter w;
  w.header(1700000000, static_cast<std::uint32_t>(scan) * 100000000u, "lidar");
  w.put<std::uint32_t>(1).put<std::uint32_t>(n).put<std::uint32_t>(static_cast<std::uint32_t>(fields.size()));
  for (const Field& f : fields) w.str(f.name).put<std::uint32_t>(f.offset).put<std::uint8_t>(f.type).put<std::uint32_t>(1);
  w.put<std::uint8_t>(0).put<std::uint32_t>(step).put<std::uint32_t>(step * n).put<std::uint32_t>(step * n);
  w.raw(data).put<std::uint8_t>(1);
  return w.bytes();
}

std::string recording(const pl::test::TempDir& dir, const std::string& name, Layout layout, bool shuffled = false, Beams beams = {}) {
  const std::string path = dir.path() + "/" + name + ".mcap";
  pl::McapWriter mcap(path);
  const auto schema = mcap.add_schema("sensor_msgs/msg/PointCloud2", "ros2msg", "");
  const auto channel = mcap.add_channel(schema, "/points", "cdr");
  for (int s = 0; s < kScans; ++s) {
    const std::uint64_t t = 1700000000ULL * 1000000000ULL + static_cast<std::uint64_t>(s) * 100000000ULL;
    mcap.write(channel, static_cast<std::uint32_t>(s), t, t, cloud(layout, s, shuffled, beams));
  }
  mcap.close();
  return path;
}

bool has_note(const pl::Dataset& ds, const std::string& part) {
  for (const auto& n : ds.recording_info.notes)
    if (n.find(part) != std::string::npos) return true;
  return false;
}

TEST(RecordingLayouts, ATimeFieldOfZerosIsSetAsideAndNamed) {
  pl::test::TempDir dir;
  const pl::Dataset ds = pl::open_dataset(recording(dir, "velodyne", Layout::VelodyneZeroTime));
  EXPECT_FALSE(ds.has_point_times());
  EXPECT_EQ(ds.recording_info.point_times, "field time (float32) set aside: all its values are 0: it carries no time");
  EXPECT_TRUE(has_note(ds, "a sweep is timed by its points' azimuths"));
  EXPECT_EQ(ds.meta.sensor.beams, kRings);
  const pl::Frame f = ds.load_frame(3, true);
  EXPECT_TRUE(f.times.empty());
  ASSERT_EQ(f.rings.size(), static_cast<std::size_t>(kRings * kColumns));
  for (int k = 0; k < kRings * kColumns; k += 37) EXPECT_EQ(f.rings[static_cast<std::size_t>(k)], ring_of(k));
}

TEST(RecordingLayouts, NoRingFieldPointsLaserByLaserGiveTheirRings) {
  pl::test::TempDir dir;
  const pl::Dataset ds = pl::open_dataset(recording(dir, "pcl", Layout::PclXyzi));
  EXPECT_EQ(ds.meta.sensor.beams, kRings);
  EXPECT_TRUE(has_note(ds, "rings from the points' order, laser by laser (16 turns of azimuth"));
  for (std::size_t s : {std::size_t{0}, std::size_t{5}}) {
    const pl::Frame f = ds.load_frame(s, true);
    ASSERT_EQ(f.rings.size(), static_cast<std::size_t>(kRings * kColumns));
    for (int k = 0; k < kRings * kColumns; ++k) ASSERT_EQ(f.rings[static_cast<std::size_t>(k)], ring_of(k)) << "point " << k;
    EXPECT_FLOAT_EQ(f.scan[kColumns].intensity, 1.0f);  // intensity at PointXYZI's offset 16, past the padding
  }
}

TEST(RecordingLayouts, NoRingFieldPointsInAnyOrderTakeTheirRingsFromTheBeamTableTheyFit) {
  pl::test::TempDir dir;
  const pl::Dataset ds = pl::open_dataset(recording(dir, "shuffled", Layout::PclXyzi, true));
  EXPECT_EQ(ds.meta.sensor.beams, kRings);
  EXPECT_TRUE(has_note(ds, "rings from the points' elevations against the VLP-16/RS-LiDAR-16/PandarXT16 beam table (100.0 %"))
      << (ds.recording_info.notes.empty() ? "" : ds.recording_info.notes[0]);
  const pl::Frame f = ds.load_frame(2, true);
  ASSERT_EQ(f.rings.size(), f.scan.size());
  for (std::size_t i = 0; i < f.scan.size(); ++i)  // the intensity was written as the ring
    ASSERT_EQ(f.rings[i], static_cast<std::uint16_t>(f.scan[i].intensity)) << "point " << i;
}

TEST(RecordingLayouts, NoRingFieldAndBeamsOfNoKnownSensorGiveNoBeamsAndSaySo) {
  pl::test::TempDir dir;
  const std::string path = recording(dir, "odd", Layout::PclXyzi, true, Beams{-14.3, 1.7});
  const pl::Dataset ds = pl::open_dataset(path);
  EXPECT_EQ(ds.meta.sensor.beams, 1);
  EXPECT_TRUE(has_note(ds, "fit no known sensor's beams: no beams can be chosen (name the sensor with --lidar-model"))
      << (ds.recording_info.notes.empty() ? "" : ds.recording_info.notes[0]);
  EXPECT_TRUE(ds.load_frame(0, true).rings.empty());
  // Named, a model whose beams the points do not fit is not taken either; a model without a table is said so.
  pl::DatasetOptions named;
  named.lidar_model = "VLP-16";
  EXPECT_TRUE(has_note(pl::open_dataset(path, named), "fit the beams of a VLP-16: no beams can be chosen"));
  named.lidar_model = "OS-1-64";
  EXPECT_TRUE(has_note(pl::open_dataset(path, named), "--lidar-model OS-1-64 has no fixed beam table (those that have: VLP-16"));
}

}  // namespace
