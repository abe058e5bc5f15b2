// Voxel-grid downsampling of one 120k-point HDL-64E scan at 0.2 m: pl::voxel_downsample against
// pcl::VoxelGrid on the same scan, interleaved in the same run, one thread.
//   bench_voxel [SCAN.bin] [--runs N]
// Without a scan file it uses a generated 120k-point scan.
#include <cmath>
#include <cstdio>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <random>
#include <string>

#include "bench_util.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/voxel.hpp"

namespace {

pl::Scan generated_scan() {
  std::mt19937 rng(1);
  std::normal_distribution<float> noise(0.f, 0.02f);
  pl::Scan scan;
  for (int ring = 0; ring < 64; ++ring) {
    double el = (2.0 - ring * 26.9 / 63.0) * M_PI / 180.0;
    for (int k = 0; k < 1875; ++k) {
      double az = k * 2.0 * M_PI / 1875.0;
      double r = std::min(60.0, 1.73 / std::max(0.01, -std::sin(el))) * (0.6 + 0.4 * std::abs(std::cos(2 * az)));
      scan.push_back({static_cast<float>(r * std::cos(el) * std::cos(az)) + noise(rng),
                      static_cast<float>(r * std::cos(el) * std::sin(az)) + noise(rng), static_cast<float>(r * std::sin(el)), 0.3f});
    }
  }
  return scan;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  int runs = 60;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc)
      runs = std::stoi(argv[++i]);
    else
      path = a;
  }
  pl::Scan scan = path.empty() ? generated_scan() : pl::read_kitti_bin(path);
  pcl::PointCloud<pcl::PointXYZI>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZI>);
  cloud->reserve(scan.size());
  for (const auto& p : scan) {
    pcl::PointXYZI q;
    q.x = p.x, q.y = p.y, q.z = p.z, q.intensity = p.intensity;
    cloud->push_back(q);
  }
  const double voxel = 0.2;
  std::size_t ours_n = 0, pcl_n = 0;
  std::vector<double> ours_ms, pcl_ms;
  pcl::PointCloud<pcl::PointXYZI> filtered;
  pl::bench::interleave(
      runs, [&] { ours_n = pl::voxel_downsample(scan, voxel).size(); },
      [&] {
        pcl::VoxelGrid<pcl::PointXYZI> grid;
        grid.setInputCloud(cloud);
        grid.setLeafSize(voxel, voxel, voxel);
        grid.filter(filtered);
        pcl_n = filtered.size();
      },
      ours_ms, pcl_ms);
  double ours = pl::median(ours_ms), theirs = pl::median(pcl_ms);
  std::printf("voxel grid 0.2 m, one scan of %zu points (%s), %d interleaved runs, one thread\n", scan.size(),
              path.empty() ? "generated" : path.c_str(), runs);
  std::printf("  %-24s median %7.3f ms  p90 %7.3f ms  -> %zu points\n", "pl::voxel_downsample", ours,
              pl::percentile(ours_ms, 90), ours_n);
  std::printf("  %-24s median %7.3f ms  p90 %7.3f ms  -> %zu points\n", "pcl::VoxelGrid", theirs,
              pl::percentile(pcl_ms, 90), pcl_n);
  std::printf("  speed-up over pcl::VoxelGrid: %.2fx (target >= 2x); ours %s the 5 ms budget\n", theirs / ours,
              ours <= 5.0 ? "within" : "OVER");
  return 0;
}
