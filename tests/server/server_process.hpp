// A real pl-server process for the tests: started on a free loopback port, stopped with SIGTERM
// (or killed with SIGKILL), its output kept.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "test_util.hpp"

namespace pl::test {

class ServerProcess {
 public:
  // Starts `pl-server --db DB --listen LISTEN EXTRA...` (output to DB.log, or for a database URL to
  // a file in the temporary folder) with extra environment variables, and waits for its
  // "listening" line.
  ServerProcess(const std::string& db, std::vector<std::string> extra = {}, std::vector<std::pair<std::string, std::string>> env = {},
                const std::string& listen = "127.0.0.1:0")
      : log_(db.find("://") == std::string::npos ? db + ".log" : temp_log()) {
    std::vector<std::string> args = {tool("pl-server"), "--db", db, "--listen", listen, "--threads", "2"};
    args.insert(args.end(), extra.begin(), extra.end());
    int log_fd = open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log_fd < 0) throw std::runtime_error("cannot write " + log_);
    pid_ = fork();
    if (pid_ == 0) {
      dup2(log_fd, STDOUT_FILENO);
      dup2(log_fd, STDERR_FILENO);
      close(log_fd);
      for (const auto& [k, v] : env) setenv(k.c_str(), v.c_str(), 1);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(log_fd);
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::regex re("listening on http://[^ ]*:([0-9]+)");
    while (std::chrono::steady_clock::now() < deadline) {
      drain(200);
      std::smatch m;
      if (std::regex_search(output_, m, re)) {
        port_ = std::stoi(m[1]);
        return;
      }
      int status;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("pl-server exited at start: " + output_);
      }
    }
    throw std::runtime_error("pl-server did not start: " + output_);
  }
  ~ServerProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (log_.rfind("/tmp/pl-server-", 0) == 0) unlink(log_.c_str());
  }
  static std::string temp_log() {
    static int n = 0;
    return "/tmp/pl-server-" + std::to_string(getpid()) + "-" + std::to_string(++n) + ".log";
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  bool alive() const { return pid_ > 0 && waitpid(pid_, nullptr, WNOHANG) == 0; }
  // A line of /proc/PID/status in kB ("VmRSS", "VmHWM"), or -1.
  long status_kb(const std::string& field) const {
    std::string status = read_file("/proc/" + std::to_string(pid_) + "/status");
    auto at = status.find(field + ":");
    return at == std::string::npos ? -1 : std::stol(status.substr(at + field.size() + 1));
  }

  // SIGTERM and wait; returns the exit code (or -signal).
  int terminate(double timeout_s = 20.0) { return stop_with(SIGTERM, timeout_s); }
  int kill9() { return stop_with(SIGKILL, 10.0); }
  const std::string& output() {
    drain(0);
    return output_;
  }

 private:
  int stop_with(int sig, double timeout_s) {
    if (pid_ <= 0) return -1;
    kill(pid_, sig);
    auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) != pid_) {
      if (std::chrono::steady_clock::now() > deadline) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        break;
      }
      drain(20);
    }
    pid_ = -1;
    drain(0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }
  void drain(int wait_ms) {
    if (wait_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
    output_ = read_file(log_);
  }

  std::string log_;
  pid_t pid_ = -1;
  int port_ = 0;
  std::string output_;
};

}  // namespace pl::test
