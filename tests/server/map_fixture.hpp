// A real map store for the server tests: pl-map tiles a small town block written as a PCD and
// publishes it as map "town" version 1; a tokens file holds one token per role.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "test_util.hpp"

namespace pl::test {

inline const std::string kReadToken = "read-7f3a", kUploadToken = "upload-91c2", kAdminToken = "admin-5d0e";

// A small town block on a 0.2 m grid: ground, two facades and a pole, spanning several 20 m tiles
// (also on the negative side of the grid).
inline pl::Points3d street_cloud() {
  pl::Points3d pts;
  // Ground between the facades (no voxel shared with them, so voxelizing keeps every point).
  for (double x = -30.0; x < 50.0; x += 0.4)
    for (double y = -5.0; y < 21.0; y += 0.4) pts.emplace_back(x + 0.1, y + 0.1, 0.02 * x);
  for (double x = -28.0; x < 45.0; x += 0.2)
    for (double z = 0.2; z < 8.0; z += 0.2) pts.emplace_back(x + 0.1, 22.1, z + 0.1), pts.emplace_back(x + 0.1, -6.1, z + 0.1);
  for (double z = 0.0; z < 6.0; z += 0.2) pts.emplace_back(5.1, 5.1, z + 0.1);
  return pts;
}

struct MapFixture {
  TempDir dir;
  std::string db;
  pl::Points3d cloud = street_cloud();

  // In a SQLite file of its own, or in the database `db_url` names (an empty PostgreSQL one).
  explicit MapFixture(const std::string& db_url = "") : db(db_url.empty() ? dir / "maps.sqlite" : db_url) {
    pl::write_pcd(dir / "street.pcd", cloud, std::vector<float>(cloud.size(), 0.5f), pl::GeoPoint{49.0, 8.4, 110.0});
    // Intensity stored (the viewer's colour, which its tests read); normals not (pl-map's default).
    auto r = pl::test::run(pl::test::tool("pl-map") + " tile --cloud " + (dir / "street.pcd") + " --db " + db + " --map town --intensity-bits 4");
    if (r.exit_code != 0) throw std::runtime_error(r.output);
    r = pl::test::run(pl::test::tool("pl-map") + " publish --db " + db + " --map town --version 1");
    if (r.exit_code != 0) throw std::runtime_error(r.output);
    pl::test::write_file(dir / "tokens.txt", "read " + kReadToken + "\nupload " + kUploadToken + "\nadmin " + kAdminToken + "\n");
  }
  std::vector<std::string> token_args() { return {"--tokens", dir / "tokens.txt"}; }
};

}  // namespace pl::test
