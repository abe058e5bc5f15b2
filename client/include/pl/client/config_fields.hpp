// Every setting of a VehicleLocalizerConfig by name, for a ROS node's parameters and for
// `pl-localize --set NAME=VALUE` / `--list-settings`: one table, so that the two cannot disagree.
//
// Names are slash-separated paths mirroring the structs, the last part the member's own name:
// "localizer/icp/kernel_m", "localizer/odometry/icp/kernel_m" (the LiDAR odometry's ICP),
// "tiles/memory_mb", "lookahead_s". The arrays of FusionConfig are one name per axis:
// "localizer/fusion/odometry_sigma/x" ... "/yaw" (x along, y across, z, roll, pitch, yaw).
//
// Covered: every number, bool and string of VehicleLocalizerConfig and of the structs in it
// (LocalizerConfig, ScanPrepConfig, RoiMapConfig, IcpConfig, FusionConfig, MotionConfig,
// IntegrityConfig, PlaceConfig, LidarOdometryConfig, PoseSearch, TileClientConfig). Left out:
// - base_from_lidar, base_from_antenna (Eigen): extrinsics are the vehicle's frame tree (a ROS
//   node's TF, a drive's meta.json), not tuning; six numbers of a pose would also invite mixing up
//   conventions (roll-pitch-yaw order, which frame in which).
// - on_wait (a callback): the program's own, to say what the start waits for.
// - tiles/version (std::optional<long long>): "unset" (the map's current version) has no value of
//   its own among these types; pin a version with the caller's own option (pl-localize --map-version).
// None of these structs holds an enum or a vector; FusionConfig's two std::array<double, 6> are
// covered axis by axis. 136 settings in all (tests/client/test_config_fields.cpp checks the table
// against every struct's member count, as the compiler counts it).
// The map source is covered (tiles/server, tiles/map, store_path, tiles/token, tiles/cache_path):
// a ROS node takes all of it as parameters. pl-localize refuses --set for the few names it sets
// itself from its options and the drive (--list-settings marks them).
//
// Setting a value parses it and nothing more: ranges are the consumer's to check (the localizer
// checks every setting of its own with check_localizer_config when constructed; the tile client
// checks what it must).
#pragma once

#include <cstddef>
#include <string>
#include <variant>
#include <vector>

#include "pl/client/vehicle_localizer.hpp"

namespace pl::client {

struct ConfigField {
  std::string name;                                                      // "localizer/scan/voxel_m"
  std::variant<double*, int*, bool*, std::size_t*, std::string*> value;  // into the config given
  std::string help;                                                      // one line: what it does, its unit
};

// Every setting of `cfg`, in the order of the structs' members; the pointers are into `cfg`.
std::vector<ConfigField> config_fields(VehicleLocalizerConfig& cfg);
// The localizer's part alone, named as above ("localizer/icp/kernel_m").
std::vector<ConfigField> config_fields(LocalizerConfig& cfg);

// The localizer's settings in range: every number finite and >= 0, scales and counts that are
// divided by or iterated over > 0, shares at most 1, factors at least 1, the field of view at most
// 360 deg, min_range_m below max_range_m. Throws pl::Error naming the first setting out of range by
// its path (what --set and a ROS node's parameters call it), its value and what it takes. The
// Localizer checks its config with it when constructed.
void check_localizer_config(const LocalizerConfig& cfg);
// One setting's range (the rules above; settings outside localizer/ have none here): "" when in
// range, else "NAME must be > 0, got -1 (what it does)".
std::string config_field_range_problem(const ConfigField& field);

// Parses `text` into the setting `name`. Numbers: finite, in C notation ("0.5", "1e-3"); whole
// numbers: no fraction, within the member's type; bools: true/false, 1/0, on/off, yes/no; strings:
// taken as they are. Throws pl::Error for a name that is not a setting (suggesting the closest names)
// and for text that does not parse (naming the type expected).
void set_config_field(VehicleLocalizerConfig& cfg, const std::string& name, const std::string& text);
void set_config_field(const ConfigField& field, const std::string& text);

// The setting's current value as text that set_config_field reads back to the same value: numbers
// in their shortest exact form ("0.1", "0.00015"), bools as true/false.
std::string config_field_text(const ConfigField& field);
// What the setting takes: "a number", "a whole number", "a whole number >= 0", "true or false", "text".
const char* config_field_type(const ConfigField& field);

// pl-localize's --set NAME=VALUE and --list-settings over this table. The few settings pl-localize
// sets itself from its options and the drive (the beams, the map source) are refused by --set,
// naming the option to use, and marked in the list.
//
// What is wrong with one --set NAME=VALUE ("" when nothing): no '=', a name pl-localize sets
// itself, a name that is not a setting, a value that does not parse or is out of range. Checked
// against a scratch config: apply_settings applies the value.
std::string setting_problem(const std::string& name_value);
// The --set NAME=VALUE settings, each checked by setting_problem, in their order.
void apply_settings(VehicleLocalizerConfig& cfg, const std::vector<std::string>& settings);
// --list-settings: one line a setting, NAME=VALUE (cfg's, with `settings` applied), then what it
// does and what it takes.
std::string settings_list(VehicleLocalizerConfig cfg, const std::vector<std::string>& settings);

}  // namespace pl::client
