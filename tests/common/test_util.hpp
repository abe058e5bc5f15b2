// Helpers shared by the tests: a temporary folder that removes itself, file writing, and running
// the built command-line tools.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>

namespace pl::test {

// A TCP port on 127.0.0.1 nobody listens on right now (the kernel's pick for port 0).
inline int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error("socket() failed");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0;
  close(fd);
  if (!ok) throw std::runtime_error("cannot find a free TCP port on 127.0.0.1");
  return ntohs(addr.sin_port);
}

class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "pl-test-XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// "0a1b..." as the bytes it spells (two hex digits a byte).
inline std::string from_hex(const std::string& hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) out.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

inline void write_file(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << text;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Path of a built executable: ctest sets PL_BIN (the build tree's bin/ otherwise). A tool this build
// does not make comes from PL_TOOLS_DIR (./pl test's ThreadSanitizer build takes pl-map from build/asan).
inline std::string tool(const std::string& name) {
  const char* bin = std::getenv("PL_BIN");
  const std::string own = std::string(bin ? bin : PL_BINARY_DIR "/bin") + "/" + name;
#ifdef PL_TOOLS_DIR
  if (*PL_TOOLS_DIR && access(own.c_str(), X_OK) != 0) return std::string(PL_TOOLS_DIR) + "/" + name;
#endif
  return own;
}

struct RunResult {
  int exit_code;
  std::string output;  // stdout and stderr together
};

inline RunResult run(const std::string& command) {
  std::string cmd = command + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// Polls until `done` or the deadline (a generous one: sanitizer builds on a busy machine are slow).
// Returns whether `done` came true.
template <class F>
bool eventually(F done, double seconds = 30.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

// Test data made once per build tree under build/test-data/NAME: `make` fills a temporary folder,
// which is then renamed into place (tests run as separate processes, possibly in parallel: the
// first to finish wins, the others' copies are dropped). Returns the folder.
inline std::string made_once(const std::string& name, const std::function<void(const std::string& folder)>& make) {
  const std::string dir = std::string(PL_BINARY_DIR) + "/test-data/" + name;
  if (std::filesystem::exists(dir + "/done")) return dir;
  TempDir tmp;
  const std::string d = tmp / "d";
  std::filesystem::create_directories(d);
  make(d);
  write_file(d + "/done", "");
  std::filesystem::create_directories(std::filesystem::path(dir).parent_path());
  std::error_code ec;
  std::filesystem::rename(d, dir, ec);  // another process may have won the race: fine
  if (!std::filesystem::exists(dir + "/done")) throw std::runtime_error("could not make " + dir);
  return dir;
}

}  // namespace pl::test
