#include "pl/common/pcd.hpp"

#include <cmath>
#include <cstdio>
#include <memory>

#include "pl/common/error.hpp"

namespace pl {

void write_pcd(const std::string& path, const Points3d& points, const std::vector<float>& intensity) {
  if (!intensity.empty() && intensity.size() != points.size()) throw Error("write_pcd: one intensity per point expected");
  for (const auto& p : points)
    if (!(p.cwiseAbs().maxCoeff() < 1.0e5))
      throw Error(path + ": coordinates beyond 100 km do not fit float32 PCD fields; write the cloud in a local frame");
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw Error(path + ": cannot write");
  std::fprintf(f.get(),
               "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n"
               "TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH %zu\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %zu\nDATA binary\n",
               points.size(), points.size());
  std::vector<float> buf;
  buf.reserve(4 * 65536);
  for (std::size_t i = 0; i < points.size(); ++i) {
    buf.push_back(static_cast<float>(points[i].x()));
    buf.push_back(static_cast<float>(points[i].y()));
    buf.push_back(static_cast<float>(points[i].z()));
    buf.push_back(intensity.empty() ? 0.0f : intensity[i]);
    if (buf.size() >= 4 * 65536 || i + 1 == points.size()) {
      if (std::fwrite(buf.data(), sizeof(float), buf.size(), f.get()) != buf.size()) throw Error(path + ": write failed (disk full?)");
      buf.clear();
    }
  }
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed (disk full?)");
}

}  // namespace pl
