// What a drive tells the map service (see the header): the status reporter fed from the
// localizer's scans, and the change report made when the drive ends.
#include "pl/client/drive_reports.hpp"

#include <ctime>
#include <filesystem>
#include <fstream>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/schema/change_report.hpp"

namespace pl::client {

DriveReports::DriveReports(DriveReportsConfig cfg, VehicleLocalizerConfig& loc_cfg)
    : cfg_(std::move(cfg)), map_(loc_cfg.tiles.map), voxel_m_(loc_cfg.changes.voxel_m) {
  loc_cfg.changes.enabled = cfg_.change_report();
  if (!cfg_.spool.empty()) {
    ReportOutboxConfig oc;
    oc.dir = cfg_.spool;
    oc.server = cfg_.server;
    oc.token = cfg_.token;
    oc.http.ca_file = loc_cfg.tiles.ca_file;
    oc.http.insecure_http = loc_cfg.tiles.insecure_http;
    outbox_ = std::make_unique<ReportOutbox>(oc);
  }
  if (cfg_.status_every_s > 0) {
    StatusReporterConfig sc;
    sc.server = cfg_.server;
    sc.token = cfg_.token;
    sc.map = map_;
    sc.vehicle = cfg_.vehicle;
    sc.every_s = cfg_.status_every_s;
    sc.http.ca_file = loc_cfg.tiles.ca_file;
    sc.http.insecure_http = loc_cfg.tiles.insecure_http;
    sc.http.timeout_s = 2.0;
    status_ = std::make_unique<StatusReporter>(sc);
  }
}

void DriveReports::watch(VehicleLocalizer& loc, const Eigen::Isometry3d& base_from_lidar) {
  if (!status_) return;
  const Eigen::Isometry3d lidar_to_base = base_from_lidar.inverse();
  StatusReporter* status = status_.get();
  loc.on_scan([status, lidar_to_base](const ScanReport& r) { status->update(r.fused * lidar_to_base, r.health, r.t); });
}

void DriveReports::finish(const VehicleLocalizer& loc, const std::string& drive_dir, double span) {
  if (!cfg_.change_report()) return;
  schema::ChangeReport rep;
  rep.map = map_;
  rep.version = loc.map_version();
  rep.vehicle = cfg_.vehicle;
  rep.start = cfg_.start >= 0 ? cfg_.start : static_cast<double>(std::time(nullptr)) - span;
  rep.end = rep.start + span;
  rep.drive = cfg_.drive.empty() ? std::filesystem::path(drive_dir).filename().string() + "-" + std::to_string(static_cast<long long>(rep.start))
                                 : cfg_.drive;
  rep.voxel_m = voxel_m_;
  rep.tile_m = loc.tile_size();
  rep.tiles = loc.change_evidence();
  const std::string text = schema::change_report_json(rep);
  schema::parse_change_report(text);  // what the service will accept (names, ids, bounds)
  if (!cfg_.file.empty()) {
    const std::string tmp = cfg_.file + ".partial";
    {
      std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
      f << text;
      if (!f.flush()) throw Error(tmp + ": write failed");
    }
    std::filesystem::rename(tmp, cfg_.file);
  }
  tiles_ = rep.tiles.size();
  bytes_ = text.size();
  if (outbox_) {
    dropped_ = outbox_->put(rep);
    sent_ = outbox_->send();
  }
}

void DriveReports::print_summary(const VehicleLocalizer& loc, std::FILE* out, std::FILE* err) const {
  if (cfg_.change_report()) {
    const auto cs = loc.change_stats();
    std::fprintf(out, "  change report: evidence from %zu ok scans (%zu passed over, the next scan waiting; median %.1f ms a scan), "
                 "%zu tiles, %.1f kB -> %s\n",
                 cs.scans, cs.skipped, cs.ms.empty() ? 0.0 : percentile(cs.ms, 50), tiles_, static_cast<double>(bytes_) / 1e3,
                 cfg_.file.empty() ? cfg_.spool.c_str() : cfg_.file.c_str());
  }
  if (status_) {
    const auto st = status_->stats();
    std::fprintf(out, "  status to the map service: %zu sent, %zu failed%s%s\n", st.sent, st.failed, st.last_error.empty() ? "" : ": ",
                 st.last_error.c_str());
  }
  if (outbox_) {
    for (const auto& d : dropped_) std::fprintf(err, "pl-localize: warning: the report spool is full: dropped %s\n", d.c_str());
    std::fprintf(out, "  report spool: %zu sent (%.1f kB gzipped), %zu held by the service already, %zu refused (%s/refused), "
                 "%zu waiting%s%s\n", sent_.sent, static_cast<double>(sent_.bytes) / 1e3, sent_.already, sent_.refused,
                 cfg_.spool.c_str(), sent_.waiting, sent_.last_error.empty() ? "" : ": ", sent_.last_error.c_str());
  }
}

}  // namespace pl::client
