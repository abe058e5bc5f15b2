// Change reports on their way to the map service: a vehicle's reports wait in a spool directory
// on its disk until the service has them (POST /v1/maps/{map}/reports with the vehicle's report
// token), so that a drive out of coverage, a service that is down or a vehicle switched off loses
// nothing it can keep. The spool is bounded: beyond max_bytes the oldest reports are dropped (said
// in the return value), as a vehicle's disk is not the service's.
//
// A report is stored once per (vehicle, drive), gzipped, named by both: a report put again
// replaces the waiting one, and one sent twice is one report to the service (it answers 200 for a
// drive it holds with the same bytes). A report the service refuses for what it is (4xx: not the
// map's grid, a version it does not know, another report under that drive id) is moved to
// DIR/refused/ with the service's answer beside it, never sent again; one it could not take now
// (no connection, 5xx, 429) waits for the next send().
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pl/schema/change_report.hpp"
#include "pl/schema/http_client.hpp"

namespace pl::client {

struct ReportOutboxConfig {
  std::string dir;                           // the spool (created when missing)
  std::size_t max_bytes = std::size_t{64} << 20;  // the spool's bound (gzipped bytes)
  std::string server;                        // https://HOST[:PORT]; empty: reports only wait
  std::string token;                         // a token of the report role
  api::HttpOptions http;
  void validate() const;  // throws pl::Error naming the field
};

struct OutboxSend {
  std::size_t sent = 0;      // taken by the service now (201)
  std::size_t already = 0;   // the service held them already (200: sent before, the answer lost)
  std::size_t refused = 0;   // moved to refused/
  std::size_t waiting = 0;   // still in the spool
  std::size_t bytes = 0;     // sent, gzipped
  std::string last_error;    // why the rest wait (empty when nothing does)
};

class ReportOutbox {
 public:
  explicit ReportOutbox(ReportOutboxConfig cfg);  // creates the spool; throws pl::Error when it cannot
  // Stores the report (checked as the service checks it first: pl::Error when it would be refused).
  // Returns the names of the reports dropped, oldest first, to keep the spool within max_bytes.
  std::vector<std::string> put(const schema::ChangeReport& report);
  // Sends the waiting reports, oldest first, until one cannot be sent now.
  OutboxSend send();
  // The reports waiting, oldest first (file names), and their gzipped bytes.
  std::vector<std::string> waiting() const;
  std::size_t waiting_bytes() const;
  const ReportOutboxConfig& config() const { return cfg_; }

 private:
  ReportOutboxConfig cfg_;
};

}  // namespace pl::client
