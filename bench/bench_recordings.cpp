// Reading speed of a recording's point clouds on one core: every sensor_msgs/PointCloud2 of the file
// read (pl::bag) and decoded into a scan (pl::ros::decode_point_cloud2), in MB of cloud messages a
// second, beside a plain read() of the whole file into memory in the same run (the same bytes, the
// page cache warm for both: a warm-up pass each, then runs interleaved).
//   bench_recordings FILE... [--runs N]
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/ros_msgs.hpp"

namespace {

// Bytes of the file (of a ROS 2 bag folder: its .db3 files), read in 4 MiB blocks and touched (a
// sum), as a baseline.
std::uint64_t plain_read(const std::string& path, std::uint64_t& sum) {
  if (std::filesystem::is_directory(path)) {
    std::uint64_t total = 0;
    for (const auto& e : std::filesystem::directory_iterator(path))
      if (e.path().extension() == ".db3") total += plain_read(e.path().string(), sum);
    return total;
  }
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw pl::Error(path + ": cannot open");
  std::vector<char> buf(4 << 20);
  std::uint64_t total = 0;
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n <= 0) break;
    for (ssize_t i = 0; i < n; i += 64) sum += static_cast<unsigned char>(buf[static_cast<std::size_t>(i)]);
    total += static_cast<std::uint64_t>(n);
  }
  ::close(fd);
  return total;
}

// The clouds of a recording read and decoded; returns the bytes of cloud messages.
std::uint64_t clouds(const std::string& path, std::size_t& points) {
  auto reader = pl::bag::open(path);
  std::uint64_t bytes = 0;
  for (const pl::bag::MessageRef& m : reader->messages()) {
    const pl::bag::Topic& t = reader->topics()[m.topic];
    if (t.type != "sensor_msgs/PointCloud2") continue;
    const std::string_view data = reader->read(m);
    bytes += data.size();
    points += pl::ros::decode_point_cloud2(data, t.encoding, path).points.size();
  }
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  int runs = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) runs = std::atoi(argv[++i]);
    else files.push_back(a);
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: bench_recordings FILE... [--runs N]\n");
    return 2;
  }
  std::uint64_t sum = 0;
  std::printf("| recording | cloud messages | read + decoded | plain read of the file | ratio |\n|---|---|---|---|---|\n");
  for (const std::string& f : files) {
    std::uint64_t cloud_bytes = 0, file_bytes = 0;
    std::size_t points = 0;
    std::vector<double> ms_clouds, ms_plain;
    pl::bench::interleave(
        runs, [&] { points = 0, cloud_bytes = clouds(f, points); }, [&] { file_bytes = plain_read(f, sum); }, ms_clouds, ms_plain);
    const double mc = pl::median(ms_clouds), mp = pl::median(ms_plain);
    const double rate_clouds = cloud_bytes / 1e6 / (mc / 1e3), rate_plain = file_bytes / 1e6 / (mp / 1e3);
    std::printf("| %s | %.0f MB, %zu points | %.0f MB/s (%.0f ms) | %.0f MB/s (%.0f MB in %.0f ms) | %.2f |\n", f.c_str(), cloud_bytes / 1e6,
                points, rate_clouds, mc, rate_plain, file_bytes / 1e6, mp, rate_clouds / rate_plain);
  }
  if (sum == 42) std::printf("\n");  // keeps the plain read's touching from being optimised away
  return 0;
}
