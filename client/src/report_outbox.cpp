// The vehicle's spool of change reports (see the header). A waiting report is one file,
// "NANOSECONDS+MAP+VEHICLE+DRIVE.json.gz" ('+' is in no name or id), written whole and renamed
// into place, so a vehicle switched off mid-write leaves no half report to send.
#include "pl/client/report_outbox.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "pl/common/error.hpp"
#include "pl/common/gzip.hpp"

namespace pl::client {

namespace fs = std::filesystem;

namespace {

constexpr const char* kSuffix = ".json.gz";

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  if (!f) throw Error(p.string() + ": cannot read");
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void write_atomically(const fs::path& p, const std::string& bytes) {
  const fs::path tmp = p.string() + ".partial";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << bytes;
    if (!f.flush()) throw Error(tmp.string() + ": write failed (is the disk full?)");
  }
  fs::rename(tmp, p);
}

// The waiting reports, oldest first (their names start with the time they were put).
std::vector<fs::path> spooled(const std::string& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && name.size() > std::string(kSuffix).size() &&
        name.compare(name.size() - std::string(kSuffix).size(), std::string::npos, kSuffix) == 0)
      out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// "MAP+VEHICLE+DRIVE" of a spooled name, and its map.
std::string key_of(const std::string& name) {
  const auto plus = name.find('+');
  return name.substr(plus + 1, name.size() - plus - 1 - std::string(kSuffix).size());
}

}  // namespace

void ReportOutboxConfig::validate() const {
  if (dir.empty()) throw Error("report outbox: dir is empty (the spool directory the reports wait in)");
  if (max_bytes < (std::size_t{1} << 16)) throw Error("report outbox: max_bytes must be 64 KiB or more");
  if (!server.empty() && token.empty()) throw Error("report outbox: a server needs a token of the report role (pl-map token add --role report)");
}

ReportOutbox::ReportOutbox(ReportOutboxConfig cfg) : cfg_(std::move(cfg)) {
  cfg_.validate();
  std::error_code ec;
  fs::create_directories(fs::path(cfg_.dir) / "refused", ec);
  if (ec) throw Error(cfg_.dir + ": cannot create the report spool (" + ec.message() + ")");
}

std::vector<std::string> ReportOutbox::put(const schema::ChangeReport& report) {
  const std::string text = schema::change_report_json(report);
  schema::parse_change_report(text);  // what the service would refuse is refused here, before it waits
  const std::string gz = gzip(text, 9);  // it may wait on the disk, and goes over a mobile link
  if (gz.size() > cfg_.max_bytes)
    throw Error("the change report is " + std::to_string(gz.size()) + " bytes gzipped, more than the spool's " +
                std::to_string(cfg_.max_bytes) + " (raise max_bytes)");
  const std::string key = report.map + "+" + report.vehicle + "+" + report.drive;
  std::vector<std::string> dropped;
  for (const fs::path& p : spooled(cfg_.dir))
    if (key_of(p.filename().string()) == key) fs::remove(p);  // the drive's newer report replaces it
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  char stamp[32];
  std::snprintf(stamp, sizeof stamp, "%020lld", static_cast<long long>(ns));
  write_atomically(fs::path(cfg_.dir) / (std::string(stamp) + "+" + key + kSuffix), gz);
  // Within the bound: the oldest go first.
  auto files = spooled(cfg_.dir);
  std::size_t total = 0;
  for (const auto& p : files) total += static_cast<std::size_t>(fs::file_size(p));
  for (std::size_t i = 0; total > cfg_.max_bytes && i + 1 < files.size(); ++i) {
    total -= static_cast<std::size_t>(fs::file_size(files[i]));
    dropped.push_back(files[i].filename().string());
    fs::remove(files[i]);
  }
  return dropped;
}

std::vector<std::string> ReportOutbox::waiting() const {
  std::vector<std::string> out;
  for (const auto& p : spooled(cfg_.dir)) out.push_back(p.filename().string());
  return out;
}

std::size_t ReportOutbox::waiting_bytes() const {
  std::size_t total = 0;
  for (const auto& p : spooled(cfg_.dir)) total += static_cast<std::size_t>(fs::file_size(p));
  return total;
}

OutboxSend ReportOutbox::send() {
  OutboxSend r;
  auto files = spooled(cfg_.dir);
  r.waiting = files.size();
  if (files.empty()) return r;
  if (cfg_.server.empty()) {
    r.last_error = "no server to send to";
    return r;
  }
  std::unique_ptr<api::HttpClient> http;
  for (const fs::path& p : files) {
    const std::string name = p.filename().string();
    const std::string key = key_of(name);
    const std::string map = key.substr(0, key.find('+'));
    const std::string gz = read_all(p);
    api::HttpResponse answer;
    try {
      if (!http) http = std::make_unique<api::HttpClient>(cfg_.server, cfg_.http);
      answer = http->request("POST", "/v1/maps/" + map + "/reports", gz,
                             {{"Authorization", "Bearer " + cfg_.token}, {"Content-Type", "application/json"}, {"Content-Encoding", "gzip"}});
    } catch (const Error& e) {
      r.last_error = e.what();
      return r;
    }
    if (answer.status == 201 || answer.status == 200) {
      (answer.status == 201 ? r.sent : r.already)++;
      r.bytes += gz.size();
      fs::remove(p);
      --r.waiting;
      continue;
    }
    if (answer.status == 408 || answer.status == 429 || answer.status >= 500) {
      r.last_error = "the service answered " + std::to_string(answer.status) + ": " + answer.body;
      return r;
    }
    // Refused for what it is: kept aside with the answer, never sent again.
    const fs::path aside = fs::path(cfg_.dir) / "refused" / name;
    fs::rename(p, aside);
    write_atomically(aside.string() + ".answer", std::to_string(answer.status) + "\n" + answer.body + "\n");
    ++r.refused;
    --r.waiting;
    r.last_error = name + " refused (" + std::to_string(answer.status) + "): " + answer.body;
  }
  return r;
}

}  // namespace pl::client
