// pl-map build and tile: a map from a drive (gloam.hpp), and a cloud cut into the tiles of a staged
// version (import.hpp).
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "command.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/text.hpp"
#include "pl/maps/catalog.hpp"
#include "pl/maps/drive_record.hpp"
#include "pl/maps/gloam.hpp"
#include "pl/maps/import.hpp"
#include "pl/recordings/dataset_cli.hpp"
#include "pl/schema/store.hpp"

namespace pl::maps {

void add_build(cli::Tool& tool, std::ostream& out) {
  struct State {
    std::vector<std::string> datasets, traj_out, odometry_out;
    std::string out, report, base_map;
    pl::DatasetOptions topics;
    GloamConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("build", "merge the scans of one drive or several into a voxelized map (PCD in the first "
                             "dataset's world frame, its geodetic origin in the header) at ground-truth or LiDAR-odometry poses", [s, &out] {
    check_gloam_config(s->cfg);
    if (!s->odometry_out.empty() && s->cfg.poses != PoseSource::Lidar)
      throw pl::Error("--odometry-out needs --poses lidar (with --poses gt no odometry runs)");
    const GloamOutputs outputs{s->out, s->report, s->traj_out, s->odometry_out};
    check_gloam_outputs(outputs, s->datasets.size());
    // A base map's drives come first, opened again from where its record says they were.
    GloamBase base;
    std::vector<std::string> paths;
    if (!s->base_map.empty()) {
      const DriveRecord record = read_drive_record(drive_record_path(s->base_map));
      check_same_merge(record, s->cfg.merge, s->base_map);
      for (const RecordedDrive& d : record.drives) {
        paths.push_back(d.dataset);
        base.poses.push_back(d.poses);
        base.deskew.push_back(d.deskew);
      }
      base.origin = record.origin;
    }
    paths.insert(paths.end(), s->datasets.begin(), s->datasets.end());
    std::vector<pl::Dataset> datasets;
    datasets.reserve(paths.size());
    for (std::size_t d = 0; d < paths.size(); ++d) {
      if (d < base.poses.size() && !pl::file_exists(paths[d]) && !pl::dir_exists(paths[d]))
        throw pl::Error(paths[d] + ": the base map's drive " + std::to_string(d + 1) + " is not there: adding a drive reads the "
                        "base map's drives again; put it back at that path (or build the whole map anew without --base-map)");
      datasets.push_back(pl::open_dataset(paths[d], s->topics));
    }
    std::vector<const pl::Dataset*> drives;
    for (const pl::Dataset& ds : datasets) drives.push_back(&ds);
    pl::StageProgress bars;
    GloamObserver observer;
    observer.progress = [&](const std::string& stage, std::size_t done, std::size_t total) { bars.update(stage, done, total); };
    observer.log = [&](const std::string& line) {
      bars.finish();
      out << line << '\n';
    };
    const GloamResult r = build_gloam_map(drives, s->cfg, observer, base);
    bars.finish();
    out << write_gloam_outputs(r, outputs);
    return 0;
  });
  MapBuildConfig& merge = s->cfg.merge;
  cli::datasets_option(c, s->datasets, s->topics, "a drive to build the map from; repeat it for a map of several drives (any mix "
                       "of folders and recordings), placed by one pose graph with loops between them");
  cli::output_file(c, "--out", s->out, "where to write the map (PCD; its places and drive record beside it)")->required();
  c.add_option("--base-map", s->base_map, "add the --dataset drives to this map (a PCD pl-map build wrote, its MAP.drives.json "
               "beside it): its drives stay where they are, merged again first, so that tiles the new drives do not reach keep "
               "their bytes in pl-map tile")->type_name("MAP");
  cli::choice(c, "--poses", s->cfg.poses, "gt: the dataset's ground truth; lidar: LiDAR odometry (without --gps started at "
              "the first ground-truth pose when there is one)", {{"gt", PoseSource::GroundTruth}, {"lidar", PoseSource::Lidar}});
  c.add_flag("--gps", s->cfg.gps, "(with --poses lidar) a pose graph of keyframes over the odometry with the drive's GPS fixes "
             "(robust to multipath) sets the poses; the ground truth is not used");
  c.add_flag("--loops", s->cfg.loops, "(with --poses lidar) loop closures found by position and by a place descriptor, verified "
             "by ICP, join the graph (re-solved on each)");
  cli::output_files(c, "--traj-out", s->traj_out, "write the LiDAR pose of every scan in the map's frame, line for line with the dataset "
               "(KITTI; TUM with the scan times when FILE ends in .tum); one per --dataset, in order");
  cli::output_files(c, "--odometry-out", s->odometry_out, "(with --poses lidar) write the LiDAR odometry's pose of every scan, before --gps "
               "and --loops corrected them (moved as a whole to start where the graph put the drive's first scan), in the format "
               "of --traj-out: the drift and the correction from one run; one per --dataset");
  cli::output_file(c, "--report", s->report, "write JSON: keyframes, GPS edges and outliers, GPS residuals, loops proposed/"
                   "accepted/rejected (and why), the mean error against ground truth before and after the graph, times");
  cli::choice(c, "--deskew", s->cfg.deskew, "correct each scan for the motion during the sweep, timed by azimuth (auto: the "
              "LiDAR odometry's features for recordings without meta.json, and everything for drives with point_times/ "
              "such as pl-sim's; the merged map of a KITTI raw drive only with on, as there it did not help)",
              {{"auto", Deskew::Auto}, {"on", Deskew::On}, {"off", Deskew::Off}});
  c.add_option_function<std::string>("--loops-between", [s](const std::string& v) { s->cfg.loop.between_drives = v == "on"; },
                                     "(with --loops and several drives) on (default): loops between the drives too; off: each "
                                     "drive's loops within itself (the drives then meet only through their GPS fixes)")
      ->check(CLI::IsMember({"on", "off"}))
      ->type_name("on|off");
  c.add_option_function<std::string>("--moving", [s](const std::string& v) { s->cfg.remove_moving = v == "remove"; },
                                     "keep (default): every return is merged; remove: points of things that moved during the drives are "
                                     "left out of the map (free-space evidence: the rays of the drives' other scans passed through them, "
                                     "docs/g-loam.md)")
      ->check(CLI::IsMember({"remove", "keep"}))
      ->type_name("remove|keep");
  cli::number(c, "--voxel", merge.voxel_m, "voxel side of the map, metres", cli::above(0));
  cli::number(c, "--every", merge.every, "merge every N-th scan (the odometry still uses them all)", cli::at_least(1));
  cli::number(c, "--min-range", merge.scan.min_range_m, "returns closer than this are not merged, metres", cli::at_least(0));
  cli::number(c, "--max-range", merge.scan.max_range_m, "returns farther than this are not merged, metres", cli::above(0));
  cli::number(c, "--threads", s->cfg.loam.threads, "threads of the LiDAR odometry's correspondence search (the map does not "
              "depend on it; scans are also read one ahead on a thread of their own)", cli::between(1, 64));
}

void add_tile(cli::Tool& tool, std::ostream& out) {
  struct State {
    std::string cloud, db, map, origin, places = "auto";
    ImportConfig cfg;
  };
  auto s = std::make_shared<State>();
  CLI::App& c = tool.command("tile", "voxelize a cloud, cut it into tiles, Draco-encode them (positions; normals and intensity "
                             "when given bits) and write a new staged version (the map is created on first use; unchanged "
                             "tiles share their stored bytes)", [s, &out] {
    check_import_config(s->cfg);
    if (!s->origin.empty()) s->cfg.origin = cli::geo_point(s->origin, "--origin");
    if (s->places == "auto") s->cfg.places = pl::file_exists(places_path(s->cloud)) ? places_path(s->cloud) : "";
    else if (s->places != "none") s->cfg.places = s->places;
    const pl::Cloud cloud = pl::read_cloud(s->cloud);
    std::unique_ptr<pl::Progress> bar;
    const ImportResult r = import_cloud(s->db, s->map, cloud, s->cloud, s->cfg, [&](std::size_t done, std::size_t total) {
      if (!bar) bar = std::make_unique<pl::Progress>("encoding tiles", total);
      bar->update(done);
    });
    if (bar) bar->finish();
    const auto number = static_cast<long long>(r.version.number);
    const std::string parent = r.version.parent ? "parent v" + std::to_string(*r.version.parent) : "no parent";
    out << format_text("map %s version %lld staged (%s): %zu tiles (%zu new or changed, %zu unchanged, %zu removed), %zu points, %s\n",
          s->map.c_str(), number, parent.c_str(), r.tiles, r.changed, r.unchanged, r.removed, r.points,
          megabytes(r.bytes).c_str());
    if (r.places > 0) out << format_text("%zu places for relocalization from %s\n", r.places, s->cfg.places.c_str());
    else out << "no places: the localizer can start and relocalize only near a given pose (pl-map build writes them)\n";
    out << format_text("publish it with: pl-map publish --db %s --map %s --version %lld\n", pl::store::display_name(s->db).c_str(),
          s->map.c_str(), number);
    return 0;
  });
  c.add_option("--cloud", s->cloud, "the cloud (.pcd, .ply or .bin), in the map's local ENU frame")->required()->type_name("FILE");
  db_option(c, s->db, true);
  c.add_option("--map", s->map, "the map's name (1 to 64 of A-Z a-z 0-9 _ . -)")->required()->type_name("NAME");
  cli::geo_option(c, "--origin", s->origin, "the geodetic origin of the cloud's ENU frame (when the cloud does not record it)");
  cli::number(c, "--voxel", s->cfg.voxel_m, "voxel side, metres", cli::above(0));
  cli::number(c, "--tile-size", s->cfg.tile_size_m, "tile side, metres", cli::at_least(1));
  cli::number(c, "--normal-radius", s->cfg.normal_radius_m, "neighbourhood of the stored normals, metres (default: 3 x --voxel)",
              cli::above(0))->default_str("");
  cli::number(c, "--max-error", s->cfg.codec.max_error_m, "largest position error after decoding, metres",
              cli::above_up_to(0, 0.1));
  cli::number(c, "--normal-bits", s->cfg.codec.normal_bits, "store normals: bits of each of their two octahedral coordinates "
              "(2 to 30; 0: none, the vehicle estimates them)", cli::between(0, 30));
  cli::number(c, "--intensity-bits", s->cfg.codec.intensity_bits, "store intensity, the viewer's colour: bits of each value "
              "(0: none)", cli::between(0, 30));
  c.add_option("--note", s->cfg.note, "the version's note (default: \"tiled from CLOUD\")");
  c.add_option("--places", s->places, "the places stored with the version for relocalization: a .places FILE, none, or auto "
               "(the CLOUD's name with .places, as pl-map build writes it, when that file exists)")->type_name("FILE|none|auto");
}

}  // namespace pl::maps
