// What a drive folder holds: the layout found, scans, duration and rate, points and rings per scan
// (from a sample of scans), ground truth, GPS fixes and their status mix, sidecars. pl-dataset info.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "pl/recordings/dataset.hpp"

namespace pl::dataset {

struct InfoConfig {
  std::size_t sample = 20;  // scans read (evenly spaced) for the per-scan figures, at least 1
};

// The figures as JSON (pl-dataset info --json). progress(done, total) counts the scans read.
nlohmann::json dataset_info(const Dataset& ds, const InfoConfig& cfg, const std::function<void(std::size_t, std::size_t)>& progress = {});
// The same as a table, one figure a line.
std::string dataset_info_text(const Dataset& ds, const nlohmann::json& info);

}  // namespace pl::dataset
