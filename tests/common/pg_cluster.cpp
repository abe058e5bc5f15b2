// The tests' throw-away PostgreSQL cluster (pg_cluster.hpp says what it is).
#include "pg_cluster.hpp"
#include "test_util.hpp"

#include <pwd.h>
#include <unistd.h>

#include <pqxx/pqxx>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <stdexcept>

namespace pl::test {

namespace {

// Debian's PostgreSQL 15; PL_PG_BINDIR names another folder of initdb, pg_ctl and postgres.
std::string pg_bindir() {
  const char* env = std::getenv("PL_PG_BINDIR");
  return env && *env ? env : "/usr/lib/postgresql/15/bin";
}

}  // namespace

PgCluster& PgCluster::get() {
  // Constructed once (a failure is thrown again to every caller: each PostgreSQL test fails with it).
  static PgCluster* cluster = nullptr;
  static std::string failure;
  if (cluster) return *cluster;
  if (!failure.empty()) throw std::runtime_error(failure);
  try {
    static PgCluster instance;
    cluster = &instance;
    return instance;
  } catch (const std::exception& e) {
    failure = e.what();
    throw;
  }
}

PgCluster::PgCluster() : bindir_(pg_bindir()), owner_pid_(getpid()) {
  for (const char* tool : {"initdb", "pg_ctl", "postgres"})
    if (access((bindir_ + "/" + tool).c_str(), X_OK) != 0)
      throw std::runtime_error("PostgreSQL 15 is not installed (no " + bindir_ + "/" + tool +
                               "): the PostgreSQL tests of the map store need it. Install it with "
                               "`apt-get install postgresql` (./pl test installs it), or set PL_PG_BINDIR");
  std::string tmpl = (std::filesystem::temp_directory_path() / "pl-pg-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed for the PostgreSQL test cluster");
  dir_ = tmpl;
  if (geteuid() == 0) {
    // PostgreSQL will not run as root: the cluster is the postgres user's.
    const passwd* pw = getpwnam("postgres");
    if (!pw)
      throw std::runtime_error("running as root, and there is no postgres user for the PostgreSQL test cluster "
                               "(PostgreSQL refuses to run as root): install postgresql (./pl test installs it)");
    if (chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0)
      throw std::runtime_error("cannot give " + dir_ + " to the postgres user");
    user_ = "postgres";
    as_user_ = "runuser -u postgres -- ";
  } else {
    const passwd* pw = getpwuid(geteuid());
    if (!pw) throw std::runtime_error("the current user has no name (getpwuid)");
    user_ = pw->pw_name;
  }
  try {
    start();
  } catch (...) {
    stop();
    throw;
  }
}

// A cluster fresh from initdb, kept to copy from: ctest runs each test in a process of its own, and
// copying 40 MB is a tenth of the second initdb takes. One per user and PostgreSQL, in the temporary
// folder; written under a temporary name and renamed, so a copy is never of a half-made one.
std::string template_dir(const std::string& bindir, const std::string& user) {
  return (std::filesystem::temp_directory_path() /
          ("pl-pg-template-" + user + "-" + std::to_string(std::hash<std::string>{}(bindir) % 1000000)))
      .string();
}

void PgCluster::start() {
  const std::string data = dir_ + "/data";
  const std::string tmpl = template_dir(bindir_, user_);
  bool copied = false;
  if (access((tmpl + "/PG_VERSION").c_str(), R_OK) == 0)
    copied = run("cp -a " + tmpl + " " + data).exit_code == 0;  // -a: the owner stays postgres when root copies
  if (!copied) {
    std::error_code ec;
    std::filesystem::remove_all(data, ec);
    RunResult init = run(as_user_ + bindir_ + "/initdb -D " + data + " -U " + user_ +
                      " -A trust -E UTF8 --locale=C --no-sync --no-instructions");
    if (init.exit_code != 0) throw std::runtime_error("initdb of the PostgreSQL test cluster failed:\n" + init.output);
    const std::string partial = tmpl + ".partial-" + std::to_string(getpid());
    if (run("cp -a " + data + " " + partial).exit_code != 0 || rename(partial.c_str(), tmpl.c_str()) != 0)
      std::filesystem::remove_all(partial, ec);  // another process made it first, or no room: no matter
  }
  // The port is free when picked; another process may take it before the server binds it: retried.
  for (int attempt = 0; attempt < 5; ++attempt) {
    port_ = free_port();
    std::string problem = start_server();
    if (problem.empty()) return;
    if (attempt == 4) throw std::runtime_error("the PostgreSQL test cluster did not start:\n" + problem);
  }
}

std::string PgCluster::start_server() {
  const std::string options = "-p " + std::to_string(port_) + " -k " + dir_ +
                              " -c listen_addresses=127.0.0.1 -c fsync=off -c synchronous_commit=off "
                              "-c full_page_writes=off -c max_connections=200";
  RunResult ctl = run(as_user_ + bindir_ + "/pg_ctl -D " + dir_ + "/data -l " + dir_ + "/server.log -w -t 60 -o \"" + options +
                   "\" start");
  if (ctl.exit_code != 0) return ctl.output + "\n" + read_file(dir_ + "/server.log");
  running_ = true;
  return "";
}

void PgCluster::pause() {
  RunResult ctl = run(as_user_ + bindir_ + "/pg_ctl -D " + dir_ + "/data -m fast -w -t 60 stop");
  if (ctl.exit_code != 0) throw std::runtime_error("the PostgreSQL test cluster did not stop:\n" + ctl.output);
  running_ = false;
}

void PgCluster::resume() {
  const std::string problem = start_server();
  if (!problem.empty()) throw std::runtime_error("the PostgreSQL test cluster did not start again:\n" + problem);
}

void PgCluster::stop() noexcept {
  if (getpid() != owner_pid_) return;
  if (running_) {
    run(as_user_ + bindir_ + "/pg_ctl -D " + dir_ + "/data -m immediate stop");
    running_ = false;
  }
  if (!dir_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
}

PgCluster::~PgCluster() { stop(); }

std::string PgCluster::url(const std::string& database) const {
  return "postgresql://" + user_ + "@127.0.0.1:" + std::to_string(port_) + "/" + database;
}

std::string PgCluster::new_database() {
  // The name is this process's and a counter: unique in the cluster (which is this process's too).
  const std::string name = "pl_test_" + std::to_string(getpid()) + "_" + std::to_string(++databases_);
  pqxx::connection c(url("postgres"));
  pqxx::nontransaction w(c);
  w.exec("CREATE DATABASE " + c.quote_name(name));
  return url(name);
}

std::string pg_exec(const std::string& url, const std::string& sql) {
  try {
    pqxx::connection c(url);
    pqxx::nontransaction w(c);
    w.exec(sql);
    return "";
  } catch (const pqxx::sql_error& e) {
    return e.what();
  }
}

std::int64_t pg_scalar(const std::string& url, const std::string& sql) {
  pqxx::connection c(url);
  pqxx::nontransaction w(c);
  const pqxx::result r = w.exec(sql);
  if (r.empty() || r[0][0].is_null()) return 0;
  return r[0][0].as<std::int64_t>();
}

std::string pg_text(const std::string& url, const std::string& sql) {
  pqxx::connection c(url);
  pqxx::nontransaction w(c);
  const pqxx::result r = w.exec(sql);
  if (r.empty() || r[0][0].is_null()) return "";
  return r[0][0].as<std::string>();
}

}  // namespace pl::test
