// A throw-away PostgreSQL 15 cluster for the tests of the map store's PostgreSQL backend: one per
// test executable (process), started at first use and stopped (pg_ctl stop -m immediate) and
// removed at exit; each test takes a fresh database of its own from it.
//
// The cluster lives in a new temporary folder: initdb (trust authentication, UTF-8, fsync off; a
// copy of the first such cluster, kept in the temporary folder, as ctest runs every test in a process
// of its own), a free TCP port on 127.0.0.1, its unix socket in that folder. PostgreSQL refuses to run as root, so
// as root initdb and pg_ctl run as the Debian `postgres` user (runuser -u postgres --), which owns
// the folder; otherwise as the current user. Missing PostgreSQL binaries are an error that says to
// install them (./pl test does): the PostgreSQL variants of the tests fail, they are never skipped.
#pragma once

#include <cstdint>
#include <string>

namespace pl::test {

class PgCluster {
 public:
  // The executable's cluster, started by the first call. Throws std::runtime_error saying what is
  // missing or what failed (with the server's log).
  static PgCluster& get();

  // A new, empty database (CREATE DATABASE with a name unique in the cluster); its URL,
  // postgresql://USER@127.0.0.1:PORT/NAME.
  std::string new_database();
  // The URL of a database of the cluster, existing or not.
  std::string url(const std::string& database) const;

  // Stops the server (the databases stay), then starts it again on the same port: a restart as an
  // operator, an upgrade or a crash makes one. Throws std::runtime_error when either fails.
  void pause();
  void resume();

  const std::string& user() const { return user_; }
  int port() const { return port_; }

  PgCluster(const PgCluster&) = delete;
  PgCluster& operator=(const PgCluster&) = delete;
  ~PgCluster();

 private:
  PgCluster();
  void start();
  std::string start_server();  // "" when started, else what went wrong
  void stop() noexcept;

  std::string bindir_, dir_, user_, as_user_;  // as_user_: "runuser -u postgres -- " as root, else ""
  int port_ = 0;
  int owner_pid_ = 0;  // forked children (the crash tests) never stop the parent's cluster
  int databases_ = 0;
  bool running_ = false;
};

// SQL straight on a database, past the store (how the tests look under it and tamper with it).
// pg_exec returns "" on success, else PostgreSQL's message; the others throw std::runtime_error
// when the query fails.
std::string pg_exec(const std::string& url, const std::string& sql);
std::int64_t pg_scalar(const std::string& url, const std::string& sql);  // first column of the first row (0: none)
std::string pg_text(const std::string& url, const std::string& sql);     // "" for no row or NULL

}  // namespace pl::test
