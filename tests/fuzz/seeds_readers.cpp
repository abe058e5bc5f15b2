// Seeds of the file readers' fuzz targets (pcd, ply, kitti_bin, dataset): files written by the
// project's own writers (write_pcd, write_kitti_bin, write_meta) and, for what other tools write
// (ascii PCD, PLY from CloudCompare/Open3D, KITTI text files), small files in their documented
// layouts, and PCD files that PCL 1.13 wrote (binary_compressed among them). Each seed is a few
// hundred bytes: the fuzzer grows them.
#include <liblzf/lzf.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/scan.hpp"
#include "pl/registration/place_index.hpp"
#include "seeds.hpp"

namespace fs = std::filesystem;

namespace {

// The bytes a writer puts in a file: it writes into a scratch folder, the bytes are read back.
std::string written_by(const std::function<void(const std::string& path)>& write) {
  std::string tmpl = (fs::temp_directory_path() / "pl-seeds-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw pl::Error("make_fuzz_seeds: cannot create a scratch folder");
  const std::string path = tmpl + "/file";
  write(path);
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove_all(tmpl);
  return bytes;
}

template <typename T>
void append_raw(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

// A few returns of two lasers, stored laser by laser like KITTI (each laser one turn from just left
// of straight ahead), so that the ring finder has rings to find.
pl::Scan small_scan(int per_ring, int rings, float shift = 0.0f) {
  pl::Scan s;
  for (int r = 0; r < rings; ++r)
    for (int k = 0; k < per_ring; ++k) {
      const float a = 0.05f + 6.2f * static_cast<float>(k) / static_cast<float>(per_ring);
      const float range = 10.0f + 2.0f * static_cast<float>(r) + shift;
      s.push_back({range * std::cos(a), range * std::sin(a), -1.5f + 0.1f * static_cast<float>(r), 0.25f * static_cast<float>(k % 4)});
    }
  return s;
}

pl::Points3d points_of(const pl::Scan& s) {
  pl::Points3d p;
  for (const auto& q : s) p.emplace_back(q.x, q.y, q.z);
  return p;
}

std::vector<float> intensity_of(const pl::Scan& s) {
  std::vector<float> v;
  for (const auto& q : s) v.push_back(q.intensity);
  return v;
}

std::string from_hex(const std::string& hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) out += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  return out;
}

// A PCD binary_compressed body: the compressed and the uncompressed size, then the LZF data of
// `plain` (the points' values field after field).
std::string lzf_body(const std::string& plain) {
  std::string packed(plain.size() * 2 + 64, '\0');
  const unsigned n =
      lzf_compress(plain.data(), static_cast<unsigned>(plain.size()), packed.data(), static_cast<unsigned>(packed.size()));
  if (n == 0 && !plain.empty()) throw pl::Error("make_fuzz_seeds: lzf_compress failed");
  packed.resize(n);
  std::string out;
  append_raw<std::uint32_t>(out, n);
  append_raw<std::uint32_t>(out, static_cast<std::uint32_t>(plain.size()));
  return out + packed;
}

void pcd_seeds(const pl::fuzz::PutSeed& put) {
  const pl::Scan s = small_scan(4, 2);
  put("binary-write_pcd", written_by([&](const std::string& p) { pl::write_pcd(p, points_of(s), intensity_of(s)); }));
  put("binary-origin", written_by([&](const std::string& p) {
        pl::write_pcd(p, points_of(small_scan(2, 1)), {}, pl::GeoPoint{49.0112128044, 8.4228850418, 112.83});
      }));
  put("binary-empty", written_by([&](const std::string& p) { pl::write_pcd(p, {}, {}); }));
  // As PCL's pcl::io::savePCDFileASCII writes an XYZRGB cloud.
  put("ascii-pcl-xyzrgb",
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\n"
      "COUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n"
      "1.5 2.25 -0.5 4278190335\n-3.125 0.5 1 16711935\n10 20 30 65280\n");
  // Organised (WIDTH x HEIGHT, no POINTS line), doubles, an intensity and a field of COUNT 3.
  put("ascii-organised-doubles",
      "VERSION .7\nFIELDS normal x y z intensity\nSIZE 4 8 8 8 4\nTYPE F F F F F\nCOUNT 3 1 1 1 1\n"
      "WIDTH 2\nHEIGHT 2\nDATA ascii\n0 0 1 1.5 2.5 3.5 0.9\n0 0 1 -1 -2 -3 0.1\n\n0 1 0 4 5 6 1\n1 0 0 7 8 9 0\n");
  // Binary with every integer type: U8 ring, I16 x, I32 y, U32 z, F64 intensity, U16 padding x2.
  std::string mixed = "VERSION 0.7\nFIELDS ring x y z intensity pad\nSIZE 1 2 4 4 8 2\nTYPE U I I U F U\nCOUNT 1 1 1 1 1 2\n"
                      "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA binary\n";
  for (int i = 0; i < 2; ++i) {
    append_raw<std::uint8_t>(mixed, static_cast<std::uint8_t>(i));
    append_raw<std::int16_t>(mixed, static_cast<std::int16_t>(-300 + i));
    append_raw<std::int32_t>(mixed, 70000 * (i + 1));
    append_raw<std::uint32_t>(mixed, 5u + static_cast<std::uint32_t>(i));
    append_raw<double>(mixed, 0.5 * i);
    append_raw<std::uint16_t>(mixed, 0);
    append_raw<std::uint16_t>(mixed, 0xffff);
  }
  put("binary-mixed-types", mixed);

  // What PCL 1.13 wrote (pcl::io::savePCDFile*, pcl::PCDWriter): an organised 3 x 2 PointXYZI cloud
  // with two NaN points (no return), binary_compressed and ascii; and a driver's record with a uint16
  // intensity and a uint8 ring, where the padding becomes fields "_" in binary and is left out of the
  // compressed columns.
  const std::string pcl = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  const std::string xyzi = pcl +
                           "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 2\n"
                           "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";
  put("binary_compressed-pcl-organised-nan",
      xyzi + "DATA binary_compressed\n" +
          from_hex("51000000600000000f0000c03f0000c07f0080c942000000bf600b06004041000010c0600b068048430000803e600b02"
                   "0058c12023a00b0040201f01e04080170064202f00202003200001807f202f00402017200002ff7f47"));
  put("ascii-pcl-organised-nan", xyzi +
                                     "DATA ascii\n1.5 -2.25 0.125 10\nnan nan nan 0\n100.75 200.5 -3 255.5\n"
                                     "-0.5 0.25 7 3\nnan nan nan 0\n12 -13.5 14.25 65535\n");
  const std::string ring = "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n";
  put("binary_compressed-pcl-ring",
      pcl + "FIELDS x y z intensity ring\nSIZE 4 4 4 2 1\nTYPE F F F U U\nCOUNT 1 1 1 1 1\n" + ring + "DATA binary_compressed\n" +
          from_hex("280000002d0000000f0000a0bf0000c07f0000f44100002040800b0521c20000403f800b0a803f0700000060ea00010f"));
  put("binary-pcl-ring-padding",
      pcl + "FIELDS x y z _ intensity ring _\nSIZE 4 4 4 1 2 1 1\nTYPE F F F U U U U\nCOUNT 1 1 1 4 1 1 5\n" + ring +
          "DATA binary\n" +
          from_hex("0000a0bf000020400000403fabababab070000cdcdcdcdcd0000c07f0000c07f0000c07fabababab000001cdcdcdcdcd"
                   "0000f441000021c20000803fabababab60ea0fcdcdcdcdcd"));
  // Columns with the padding in (as Open3D's reader expects them), every scalar type, repeated
  // rows for LZF back references; and the empty cloud PCL writes (both sizes 0).
  std::string x, y, z, pad, in, t;
  for (int i = 0; i < 24; ++i) {
    append_raw<double>(x, i % 6 == 5 ? NAN : 0.5 * (i % 6));  // one point of each row without a return
    append_raw<std::int16_t>(y, static_cast<std::int16_t>(-100 + i % 6));
    append_raw<std::uint32_t>(z, 7u);
    pad += std::string(3, '\0');
    append_raw<std::uint8_t>(in, static_cast<std::uint8_t>(i % 6 == 1 ? 255 : 10 * i));
    append_raw<float>(t, 0.01f * static_cast<float>(i));
  }
  put("binary_compressed-padded-types",
      "VERSION 0.7\nFIELDS x y z _ intensity t\nSIZE 8 2 4 1 1 4\nTYPE F I U U U F\nCOUNT 1 1 1 3 1 1\nWIDTH 6\nHEIGHT 4\n"
      "POINTS 24\nDATA binary_compressed\n" +
          lzf_body(x + y + z + pad + in + t));
  put("binary_compressed-empty",
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 0\nHEIGHT 1\nPOINTS 0\n"
      "DATA binary_compressed\n" +
          std::string(8, '\0'));
}

void ply_seeds(const pl::fuzz::PutSeed& put) {
  // As CloudCompare writes an ascii cloud with a scalar field.
  put("ascii-cloudcompare",
      "ply\nformat ascii 1.0\ncomment Created by CloudCompare v2.12\nobj_info Generated by CloudCompare!\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty float scalar_intensity\nend_header\n1 2 3 255 0 0 0.5\n-1.5 2.25 0 0 255 0 0.25\n"
      "100 -200 3.5 0 0 255 1\n");
  // With Windows line ends and a face element after the vertices (a mesh).
  put("ascii-crlf-mesh",
      "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\n"
      "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
  // As Open3D writes a binary cloud: doubles, then colours.
  std::string open3d = "ply\nformat binary_little_endian 1.0\ncomment Created by Open3D\nelement vertex 2\n"
                       "property double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\n"
                       "property uchar blue\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    append_raw<double>(open3d, 1.25 * i);
    append_raw<double>(open3d, -2.5);
    append_raw<double>(open3d, 100.0 + i);
    for (int c = 0; c < 3; ++c) append_raw<std::uint8_t>(open3d, static_cast<std::uint8_t>(80 * c));
  }
  put("binary-open3d", open3d);
  // float32 with intensity and every integer type.
  std::string ints = "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                     "property float z\nproperty float intensity\nproperty char a\nproperty short b\nproperty ushort c\n"
                     "property int d\nproperty uint e\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    for (float v : {1.0f + i, 2.0f, -3.0f, 0.75f}) append_raw<float>(ints, v);
    append_raw<std::int8_t>(ints, -1);
    append_raw<std::int16_t>(ints, -2);
    append_raw<std::uint16_t>(ints, 3);
    append_raw<std::int32_t>(ints, -4);
    append_raw<std::uint32_t>(ints, 5);
  }
  put("binary-float-intensity", ints);
}

void kitti_bin_seeds(const pl::fuzz::PutSeed& put) {
  auto bin = [](const pl::Scan& s) { return written_by([&](const std::string& p) { pl::write_kitti_bin(p, s); }); };
  put("empty", bin({}));
  put("one-point", bin({{1.5f, -2.25f, 0.125f, 0.5f}}));
  put("two-rings", bin(small_scan(12, 2)));
  put("four-rings", bin(small_scan(8, 4, 30.0f)));
}

// Places as pl-map build encodes them: none, and a few of a small grid with occupied and empty cells.
void places_seeds(const pl::fuzz::PutSeed& put) {
  pl::registration::PlaceDescriptorConfig cfg;
  cfg.rings = 3;
  cfg.sectors = 8;
  put("none", pl::registration::PlaceIndex(cfg, {}).encode());
  std::vector<pl::registration::Place> places;
  for (int k = 0; k < 3; ++k) {
    std::vector<Eigen::Vector3f> points;
    for (int i = 0; i < 12; ++i)
      points.emplace_back(static_cast<float>(5 + 20 * (i % 3)) * std::cos(0.7f * static_cast<float>(i + k)),
                          static_cast<float>(5 + 20 * (i % 3)) * std::sin(0.7f * static_cast<float>(i + k)),
                          static_cast<float>(i % 4) - 1.5f);
    pl::registration::Place p;
    p.position = Eigen::Vector3d(2.0 * k, -1.0, 0.5);
    p.yaw = 0.3 * k;
    p.descriptor = pl::registration::make_place_descriptor(points, cfg);
    places.push_back(p);
  }
  put("three", pl::registration::PlaceIndex(cfg, places).encode());
}

// ---- dataset: one input holds a whole folder, "@@ PATH" before each file ----

using Files = std::map<std::string, std::string>;

std::string folder_input(const Files& files) {
  std::string out;
  for (const auto& [path, bytes] : files) {
    // The target splits at "\n@@ ": a scan's bytes must not contain it.
    if (bytes.find("\n@@ ") != std::string::npos) throw pl::Error("make_fuzz_seeds: " + path + " contains the separator");
    // The newline before the next "@@ " belongs to the separator; the last file runs to the end.
    if (!out.empty()) out += "\n";
    out += "@@ " + path + "\n" + bytes;
  }
  return out;
}

std::string scan_bytes(int frame) {
  return written_by([&](const std::string& p) { pl::write_kitti_bin(p, small_scan(3, 1, static_cast<float>(frame))); });
}

std::string meta_bytes(const pl::DatasetMeta& m) {
  return written_by([&](const std::string& p) { pl::write_meta(p, m); });
}

// Frame k's KITTI pose: a little forward motion and yaw.
std::string kitti_pose_line(int k) {
  char line[160];
  const double c = std::cos(0.01 * k), s = std::sin(0.01 * k);
  std::snprintf(line, sizeof(line), "%.9f %.9f 0 %.3f %.9f %.9f 0 %.3f 0 0 1 0.01\n", c, -s, 1.5 * k, s, c, 0.1 * k);
  return line;
}

// An OXTS record of 30 values near Karlsruhe (lat lon alt roll pitch yaw vn ve vf vl vu ax ay az af al au
// wx wy wz wf wl wu pos_accuracy vel_accuracy navstat numsats posmode velmode orimode).
std::string oxts_line(int k, int posmode) {
  char line[320];
  std::snprintf(line, sizeof(line),
                "%.9f %.9f %.3f 0.01 -0.02 %.4f 1 2 10 0 0 0 0 9.8 0 0 9.8 0 0 0.1 0 0 0.1 0.05 0.02 4 10 %d 4 0\n",
                49.0112128 + 1e-5 * k, 8.422885 + 2e-5 * k, 112.8 + 0.05 * k, -1.2 + 0.01 * k, posmode);
  return line;
}

void dataset_seeds(const pl::fuzz::PutSeed& put) {
  put("odometry-minimal", folder_input({{"velodyne/000000.bin", scan_bytes(0)}, {"times.txt", "0.0\n"}}));

  // A sample of frames (0 and 2), cam0 poses with calib.txt, and every sidecar.
  pl::DatasetMeta meta;
  meta.sensor.model = "VLP-16";
  meta.sensor.beams = 16;
  meta.sensor.point_order = "any";
  for (int i = 0; i < 16; ++i) meta.sensor.vertical_angles_deg.push_back(-15.0 + 2.0 * i);
  meta.sensor.fov_deg = 180;
  meta.vehicle.wheel_base_m = 1.6;
  meta.vehicle.gps_lever_arm = Eigen::Vector3d(0.5, 0, 1.2);
  meta.origin = pl::GeoPoint{49.0, 8.4, 100.0};
  put("odometry-full",
      folder_input({{"velodyne/000000.bin", scan_bytes(0)},
                    {"velodyne/000002.bin", scan_bytes(2)},
                    {"times.txt", "0\n0.1\n0.2\n"},
                    {"poses.txt", kitti_pose_line(0) + kitti_pose_line(1) + kitti_pose_line(2)},
                    {"calib.txt", "P0: 718.856 0 607.1928 0 0 718.856 185.2157 0 0 0 1 0\n"
                                  "Tr: 4.276802385584e-04 -9.999672484946e-01 -8.084491683471e-03 -1.198459927713e-02 "
                                  "-7.210626507497e-03 8.081198471645e-03 -9.999413164504e-01 -5.403984729748e-02 "
                                  "9.999738645903e-01 4.859485810390e-04 -7.206933692422e-03 -2.921968648686e-01\n"},
                    {"meta.json", meta_bytes(meta)},
                    {"gps.csv", "t,lat,lon,alt,std_m,status\n0.0,49.0,8.4,100.0,0.02,4\n0.1,49.00001,8.4,100.5,1.5,1\n"},
                    {"encoder.csv", "# wheel travel\nt,left_m,right_m\n0,0,0\n0.01,0.1,0.12\n"},
                    {"odometry.csv", "t,x,y,z,qx,qy,qz,qw\n0,1,2,3,0,0,0,1\n0.1,1.5,2,3,0,0,0.0499792,0.9987503\n"}}));

  // LiDAR poses (no calib.txt) and the default meta written out (HDL-64E, laser by laser).
  pl::DatasetMeta kitti;
  kitti.sensor.vertical_angles_deg = pl::hdl64_vertical_angles_deg();
  put("odometry-lidar-poses", folder_input({{"velodyne/000000.bin", scan_bytes(0)},
                                            {"velodyne/000001.bin", scan_bytes(1)},
                                            {"times.txt", "0.000000e+00\n1.036379e-01\n"},
                                            {"poses.txt", kitti_pose_line(0) + kitti_pose_line(1)},
                                            {"meta.json", meta_bytes(kitti)}}));

  const std::string calib_imu =
      "calib_time: 25-May-2012 16:47:16\n"
      "R: 9.999976e-01 7.553071e-04 -2.035826e-03 -7.854027e-04 9.998898e-01 -1.482298e-02 2.024406e-03 1.482454e-02 9.998881e-01\n"
      "T: -8.086759e-01 3.195559e-01 -7.997231e-01\n";
  put("raw-lidar-timestamps",
      folder_input({{"velodyne_points/data/0000000000.bin", scan_bytes(0)},
                    {"velodyne_points/data/0000000001.bin", scan_bytes(1)},
                    {"velodyne_points/timestamps.txt", "2011-09-26 13:02:25.964389445\n2011-09-26 13:02:26.074611973\n"},
                    {"oxts/data/0000000000.txt", oxts_line(0, 6)},
                    {"oxts/data/0000000001.txt", oxts_line(1, 5)},
                    {"oxts/timestamps.txt", "2011-09-26 13:02:25.951199337\n2011-09-26 13:02:26.061260254\n"},
                    {"calib_imu_to_velo.txt", calib_imu}}));

  // OXTS times only (crossing midnight), and a consumer GPS beside the drive.
  put("raw-oxts-times-gps-csv",
      folder_input({{"velodyne_points/data/0000000000.bin", scan_bytes(0)},
                    {"velodyne_points/data/0000000001.bin", scan_bytes(1)},
                    {"oxts/data/0000000000.txt", oxts_line(0, 4)},
                    {"oxts/data/0000000001.txt", oxts_line(1, 0)},
                    {"oxts/timestamps.txt", "2011-09-26 23:59:59.950000000\n2011-09-27 00:00:00.050000000\n"},
                    {"calib_imu_to_velo.txt", calib_imu},
                    {"gps.csv", "# degraded\nt,lat,lon,alt,std_m,status\n0.0,49.0112,8.42289,113.0,1.5,1\n"}}));
}

const bool registered = pl::fuzz::register_seeds("pcd", pcd_seeds) && pl::fuzz::register_seeds("ply", ply_seeds) &&
                        pl::fuzz::register_seeds("kitti_bin", kitti_bin_seeds) &&
                        pl::fuzz::register_seeds("places", places_seeds) &&
                        pl::fuzz::register_seeds("dataset", dataset_seeds);

}  // namespace
