// Headless Chromium for the viewer's tests and benchmark, driven over the DevTools protocol on a
// pipe (--remote-debugging-pipe: JSON messages ending in a NUL byte, commands on the browser's file
// descriptor 3, answers and events on its 4). No WebSocket and no npm package: the system's
// chromium (Debian's `chromium`) and nlohmann::json.
//
// WebGL with software rendering: ANGLE on SwiftShader (--use-angle=swiftshader; Chromium 137 and
// later also want --enable-unsafe-swiftshader for it). --use-gl=swiftshader leaves Debian 12's
// Chromium 156 without WebGL at all.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "pl/schema/signed_manifest.hpp"  // pl::signing::decode_base64, for screenshots

namespace pl::test {

class HeadlessChromium {
  static std::chrono::steady_clock::duration seconds(double s) {
    return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
  }

 public:
  // The browser to run: $PL_CHROMIUM, else chromium (or chromium-browser) on the PATH; empty when
  // there is none.
  static std::string find() {
    if (const char* env = std::getenv("PL_CHROMIUM"); env && *env) return access(env, X_OK) == 0 ? env : "";
    const char* path = std::getenv("PATH");
    std::string dirs = path ? path : "/usr/bin:/bin";
    for (const char* name : {"chromium", "chromium-browser"}) {
      std::size_t at = 0;
      while (at <= dirs.size()) {
        const std::size_t end = dirs.find(':', at);
        const std::string dir = dirs.substr(at, end == std::string::npos ? std::string::npos : end - at);
        const std::string full = (dir.empty() ? "." : dir) + "/" + name;
        if (access(full.c_str(), X_OK) == 0) return full;
        if (end == std::string::npos) break;
        at = end + 1;
      }
    }
    return "";
  }

  // Starts the browser with a fresh profile in `profile_dir` (which must exist; its log goes to
  // profile_dir/chromium.log) and a page of width x height CSS pixels.
  HeadlessChromium(const std::string& profile_dir, int width = 1200, int height = 750) : log_(profile_dir + "/chromium.log") {
    const std::string exe = find();
    if (exe.empty()) throw std::runtime_error("chromium is not installed (Debian: apt-get install chromium)");
    int commands[2], answers[2];
    if (pipe2(commands, O_CLOEXEC) != 0 || pipe2(answers, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
    std::vector<std::string> args = {exe,
                                     "--headless=new",
                                     "--remote-debugging-pipe",
                                     // The sandbox needs user namespaces or a setuid helper, which
                                     // containers and root lack; the pages are the test's own.
                                     "--no-sandbox",
                                     "--user-data-dir=" + profile_dir + "/profile",
                                     "--use-angle=swiftshader",
                                     "--enable-unsafe-swiftshader",
                                     "--ignore-gpu-blocklist",
                                     "--window-size=" + std::to_string(width) + "," + std::to_string(height),
                                     "--no-first-run",
                                     "--no-default-browser-check",
                                     "--disable-extensions",
                                     "--disable-background-networking",
                                     "--disable-component-update",
                                     "--disable-sync",
                                     "--disable-dev-shm-usage",
                                     "--hide-scrollbars",
                                     "--mute-audio",
                                     "about:blank"};
    const int log = open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    pid_ = fork();
    if (pid_ == 0) {
      // Out of the way of 3 and 4 first (a pipe's own descriptor may be either), then into place.
      const int in = fcntl(commands[0], F_DUPFD, 10), out = fcntl(answers[1], F_DUPFD, 10);
      dup2(in, 3);
      dup2(out, 4);
      if (log >= 0) dup2(log, STDOUT_FILENO), dup2(log, STDERR_FILENO);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    if (log >= 0) close(log);
    close(commands[0]);
    close(answers[1]);
    to_ = commands[1];
    from_ = answers[0];
    if (pid_ < 0) throw std::runtime_error("fork failed");
    try {
      const std::string target = call("Target.createTarget", {{"url", "about:blank"}}, false, 60)["targetId"];
      session_ = call("Target.attachToTarget", {{"targetId", target}, {"flatten", true}}, false, 30)["sessionId"];
      call("Page.enable", nlohmann::json::object());
      call("Runtime.enable", nlohmann::json::object());
      call("Emulation.setDeviceMetricsOverride", {{"width", width}, {"height", height}, {"deviceScaleFactor", 1}, {"mobile", false}});
    } catch (...) {
      stop();  // no destructor runs for an object whose constructor threw
      throw;
    }
  }

  ~HeadlessChromium() { stop(); }
  HeadlessChromium(const HeadlessChromium&) = delete;
  HeadlessChromium& operator=(const HeadlessChromium&) = delete;

  // Closes the browser (Browser.close, then SIGKILL if it lingers).
  void stop() {
    if (pid_ > 0) {
      try {
        call("Browser.close", nlohmann::json::object(), false, 5);
      } catch (...) {
      }
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
      while (waitpid(pid_, nullptr, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > deadline) {
          kill(pid_, SIGKILL);
          waitpid(pid_, nullptr, 0);
          break;
        }
        usleep(20000);
      }
      pid_ = -1;
    }
    if (to_ >= 0) close(to_);
    if (from_ >= 0) close(from_);
    to_ = from_ = -1;
  }

  // Loads the page and waits for its load event.
  void navigate(const std::string& url, double timeout_s = 60) {
    loaded_ = false;
    call("Page.navigate", {{"url", url}});
    const auto deadline = std::chrono::steady_clock::now() + seconds(timeout_s);
    while (!loaded_) {
      if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("the page " + url + " did not load in time");
      read_message(deadline);
    }
  }

  // The value of a JavaScript expression in the page (a promise is awaited), as JSON. Throws with
  // the page's exception.
  nlohmann::json eval(const std::string& expression, double timeout_s = 120) {
    const nlohmann::json r = call("Runtime.evaluate", {{"expression", expression}, {"awaitPromise", true}, {"returnByValue", true}}, true,
                                  timeout_s);
    if (r.contains("exceptionDetails")) {
      const auto& d = r["exceptionDetails"];
      std::string what = d.value("text", "exception");
      if (d.contains("exception") && d["exception"].contains("description")) what += ": " + d["exception"]["description"].get<std::string>();
      throw std::runtime_error("in the page: " + what + " (evaluating " + expression.substr(0, 200) + ")");
    }
    return r["result"].value("value", nlohmann::json());
  }

  // A drag with the left button from (x0, y0) to (x1, y1), CSS pixels, in `steps` moves.
  void drag(double x0, double y0, double x1, double y1, int steps = 10) {
    auto mouse = [&](const char* type, double x, double y, const char* buttons) {
      call("Input.dispatchMouseEvent", {{"type", type}, {"x", x}, {"y", y}, {"button", "left"}, {"buttons", std::atoi(buttons)}, {"clickCount", 1}});
    };
    mouse("mousePressed", x0, y0, "1");
    for (int i = 1; i <= steps; ++i) mouse("mouseMoved", x0 + (x1 - x0) * i / steps, y0 + (y1 - y0) * i / steps, "1");
    mouse("mouseReleased", x1, y1, "0");
  }

  // The page as PNG bytes.
  std::string screenshot_png() {
    const nlohmann::json r = call("Page.captureScreenshot", {{"format", "png"}});
    auto bytes = signing::decode_base64(r["data"].get<std::string>());
    if (!bytes) throw std::runtime_error("Page.captureScreenshot answered data that is not base64");
    return *bytes;
  }

  // What the page wrote to its console and the exceptions it did not catch, as "TYPE: text".
  const std::vector<std::string>& console() const { return console_; }
  const std::string& log_path() const { return log_; }

  // A DevTools command; its result. `to_page`: to the page's session, else to the browser.
  nlohmann::json call(const std::string& method, const nlohmann::json& params, bool to_page = true, double timeout_s = 60) {
    const int id = ++next_id_;
    nlohmann::json m = {{"id", id}, {"method", method}, {"params", params}};
    if (to_page) m["sessionId"] = session_;
    std::string out = m.dump() + '\0';
    for (std::size_t done = 0; done < out.size();) {
      const ssize_t n = write(to_, out.data() + done, out.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw std::runtime_error("chromium went away (see " + log_ + ")");
      done += static_cast<std::size_t>(n);
    }
    const auto deadline = std::chrono::steady_clock::now() + seconds(timeout_s);
    for (;;) {
      nlohmann::json answer = read_message(deadline);
      if (answer.value("id", -1) != id) continue;
      if (answer.contains("error")) throw std::runtime_error(method + ": " + answer["error"].dump());
      return answer["result"];
    }
  }

 private:
  // The next message (events are noted on the way: console lines, exceptions, the load event).
  nlohmann::json read_message(std::chrono::steady_clock::time_point deadline) {
    for (;;) {
      const auto end = buffer_.find('\0');
      if (end != std::string::npos) {
        nlohmann::json m = nlohmann::json::parse(buffer_.substr(0, end), nullptr, false);
        buffer_.erase(0, end + 1);
        if (m.is_discarded()) continue;
        note(m);
        return m;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0) throw std::runtime_error("chromium did not answer in time (see " + log_ + ")");
      pollfd p{from_, POLLIN, 0};
      const int ready = poll(&p, 1, static_cast<int>(std::min<long long>(left, 1000)));
      if (ready < 0 && errno == EINTR) continue;
      if (ready <= 0) continue;
      char chunk[65536];
      const ssize_t n = read(from_, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw std::runtime_error("chromium went away (see " + log_ + ")");
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }

  void note(const nlohmann::json& m) {
    const std::string method = m.value("method", "");
    if (method == "Page.loadEventFired") loaded_ = true;
    if (method == "Runtime.consoleAPICalled") {
      std::string line = m["params"].value("type", "log") + ":";
      for (const auto& a : m["params"]["args"]) {
        if (a.contains("value")) line += " " + (a["value"].is_string() ? a["value"].get<std::string>() : a["value"].dump());
        else if (a.contains("description")) line += " " + a["description"].get<std::string>();
      }
      console_.push_back(line);
    }
    if (method == "Runtime.exceptionThrown") {
      const auto& d = m["params"]["exceptionDetails"];
      console_.push_back("exception: " + (d.contains("exception") ? d["exception"].value("description", "") : d.value("text", "")));
    }
  }

  std::string log_;
  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
  std::string buffer_, session_;
  int next_id_ = 0;
  bool loaded_ = false;
  std::vector<std::string> console_;
};

}  // namespace pl::test
