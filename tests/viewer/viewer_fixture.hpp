// What the viewer's tests share: the test map of tests/server/map_fixture.hpp with a second version
// tiled by pl-map from a changed cloud (tiles added, removed and changed), a token of each role,
// and a plain socket for what an HTTP client library would tidy up (targets with "..", streams).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "map_fixture.hpp"
#include "pl/common/cloud_io.hpp"
#include "test_util.hpp"

namespace pl::test {

inline const std::string kReportToken = "report-3e8b";

// The street of street_cloud() six months later: a parked car in tile (1, 0), the pole of tile
// (0, 0) gone, a new wall in tile (5, 0) (a tile of its own: added), and everything west of
// x = -20 m gone (tiles (-2, *): removed).
inline pl::Points3d changed_street_cloud() {
  pl::Points3d out;
  for (const auto& p : street_cloud()) {
    if (p.x() < -20.0) continue;
    if (std::abs(p.x() - 5.1) < 0.01 && std::abs(p.y() - 5.1) < 0.01) continue;  // the pole
    out.push_back(p);
  }
  for (double x = 24.0; x < 28.0; x += 0.2)
    for (double y = 2.0; y < 4.0; y += 0.2)
      for (double z = 0.4; z < 1.6; z += 0.4) out.emplace_back(x + 0.1, y + 0.1, z + 0.1);
  for (double x = 104.0; x < 110.0; x += 0.2)
    for (double z = 0.2; z < 3.0; z += 0.2) out.emplace_back(x + 0.1, 10.1, z + 0.1);
  return out;
}

// Map "town": version 1 as MapFixture makes it, version 2 from changed_street_cloud() (published
// when `publish_second`, else left staged); tokens.txt also holds a report token.
struct ViewerMap : MapFixture {
  explicit ViewerMap(bool publish_second = true) {
    const auto cloud2 = changed_street_cloud();
    pl::write_pcd(dir / "street2.pcd", cloud2, std::vector<float>(cloud2.size(), 0.5f), pl::GeoPoint{49.0, 8.4, 110.0});
    auto r = run(tool("pl-map") + " tile --cloud " + (dir / "street2.pcd") + " --db " + db + " --map town --intensity-bits 4");
    if (r.exit_code != 0) throw std::runtime_error(r.output);
    if (publish_second) {
      r = run(tool("pl-map") + " publish --db " + db + " --map town --version 2");
      if (r.exit_code != 0) throw std::runtime_error(r.output);
    }
    write_file(dir / "tokens.txt", "read " + kReadToken + "\nreport " + kReportToken + "\nupload " + kUploadToken + "\nadmin " +
                                       kAdminToken + "\n");
  }
};

// One TCP connection to 127.0.0.1:port, bytes as they are.
class RawConnection {
 public:
  explicit RawConnection(int port) {
    fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("cannot connect");
  }
  ~RawConnection() { close(fd_); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  void send_text(const std::string& s) {
    for (std::size_t done = 0; done < s.size();) {
      const ssize_t n = ::send(fd_, s.data() + done, s.size() - done, MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("send failed");
      done += static_cast<std::size_t>(n);
    }
  }
  // Reads until `done(received)` or the peer closes or `timeout_s` passes; returns whether done.
  bool read_until(const std::function<bool(const std::string&)>& done, double timeout_s = 30) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!done(received_)) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0 || closed_) return false;
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char buf[16384];
      const ssize_t n = recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        closed_ = true;
        continue;
      }
      received_.append(buf, static_cast<std::size_t>(n));
    }
    return true;
  }
  bool read_contains(const std::string& text, double timeout_s = 30) {
    return read_until([&](const std::string& r) { return r.find(text) != std::string::npos; }, timeout_s);
  }
  // Waits for the peer to close (true) within the time.
  bool read_to_end(double timeout_s = 30) {
    read_until([&](const std::string&) { return closed_; }, timeout_s);
    return closed_;
  }
  const std::string& received() const { return received_; }
  // The status of the first answer received (0: none yet).
  int status() const { return received_.size() > 12 ? std::stoi(received_.substr(9, 3)) : 0; }

 private:
  int fd_ = -1;
  std::string received_;
  bool closed_ = false;
};

// A whole GET over a fresh connection, Connection: close: the raw answer.
inline std::string raw_get(int port, const std::string& target) {
  RawConnection c(port);
  c.send_text("GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  c.read_to_end();
  return c.received();
}

}  // namespace pl::test
