#include "pl/server/server.hpp"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ip/v6_only.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <sys/resource.h>
#include <sys/sendfile.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "access_log.hpp"
#include "blob_files.hpp"
#include "http_request.hpp"
#include "viewer.hpp"

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace pl::server {

namespace {

std::chrono::milliseconds ms(double s) { return std::chrono::milliseconds(static_cast<long>(s * 1000)); }

// Room for many connections: raise the descriptor limit towards the hard limit (65,536 at most).
void raise_fd_limit() {
  rlimit rl{};
  if (getrlimit(RLIMIT_NOFILE, &rl) != 0) return;
  rlim_t want = std::min<rlim_t>(rl.rlim_max, 65536);
  if (rl.rlim_cur < want) {
    rl.rlim_cur = want;
    setrlimit(RLIMIT_NOFILE, &rl);
  }
}

}  // namespace

struct Server::Impl {
  ServerConfig cfg;
  Metrics metrics;
  Api api;
  net::io_context ioc;
  std::vector<std::unique_ptr<tcp::acceptor>> acceptors;  // one per address the host resolves to
  net::signal_set signals;
  std::atomic<bool> stopping{false};
  BlobFiles blob_files;

  explicit Impl(ServerConfig c)
      : cfg(std::move(c)), api(cfg.api, metrics), ioc(std::max(1, cfg.threads)), signals(ioc, SIGINT, SIGTERM) {
    raise_fd_limit();
    // A literal address, or a name: every address it resolves to ("localhost": 127.0.0.1 and ::1).
    // With port 0 the first gets a free port and the others the same one.
    tcp::resolver resolver(ioc);
    beast::error_code ec;
    auto results = resolver.resolve(cfg.host, std::to_string(cfg.port), tcp::resolver::passive | tcp::resolver::numeric_service, ec);
    if (ec || results.empty())
      throw Error("--listen: cannot resolve \"" + cfg.host + "\" (" + ec.message() + "): give an address (127.0.0.1, ::1, 0.0.0.0) or a known host name");
    std::uint16_t port = cfg.port;
    std::string errors;
    std::vector<tcp::endpoint> seen;
    for (const auto& r : results) {
      tcp::endpoint ep(r.endpoint().address(), port);
      if (std::find(seen.begin(), seen.end(), ep) != seen.end()) continue;
      seen.push_back(ep);
      auto a = std::make_unique<tcp::acceptor>(ioc);
      beast::error_code bec;
      a->open(ep.protocol(), bec);
      if (!bec) a->set_option(net::socket_base::reuse_address(true), bec);
      if (!bec && ep.address().is_v6()) a->set_option(net::ip::v6_only(true), bec);  // v4 and v6 side by side
      if (!bec) a->bind(ep, bec);
      if (!bec) a->listen(net::socket_base::max_listen_connections, bec);
      if (bec) {
        errors += (errors.empty() ? "" : "; ") + ep.address().to_string() + ": " + bec.message();
        continue;
      }
      if (port == 0) port = a->local_endpoint().port();
      acceptors.push_back(std::move(a));
    }
    if (acceptors.empty()) throw Error("--listen " + cfg.host + ":" + std::to_string(cfg.port) + ": cannot listen (" + errors + ")");
    if (!errors.empty()) std::fprintf(stderr, "pl-server: not listening on every address of %s (%s)\n", cfg.host.c_str(), errors.c_str());
  }

  // One connection: read a request, answer it, repeat while kept alive.
  class Session : public std::enable_shared_from_this<Session> {
   public:
    Session(tcp::socket&& socket, Impl& server) : stream_(std::move(socket)), server_(server) {
      beast::error_code ec;
      auto ep = stream_.socket().remote_endpoint(ec);
      remote_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
      if (!ec) {
        const auto a = ep.address();
        loopback_ = a.is_loopback() || (a.is_v6() && a.to_v6().is_v4_mapped() &&
                                        net::ip::make_address_v4(net::ip::v4_mapped, a.to_v6()).is_loopback());
      }
      ++server_.metrics.open_connections;
    }
    ~Session() {
      busy(false);
      --server_.metrics.open_connections;
      std::lock_guard<std::mutex> lock(server_.sessions_mutex);
      server_.sessions.erase(this);
    }

    void start() {
      {
        std::lock_guard<std::mutex> lock(server_.sessions_mutex);
        server_.sessions[this] = weak_from_this();
      }
      net::dispatch(stream_.get_executor(), beast::bind_front_handler(&Session::read, shared_from_this()));
    }

    // On shutdown: a connection waiting for its next request is closed now; one in the middle of a
    // request finishes it (the response says Connection: close).
    void drain() {
      net::dispatch(stream_.get_executor(), [self = shared_from_this()] {
        if (self->events_) return self->end_events();  // an event stream has no end of its own
        if (self->idle_ && self->buffer_.size() == 0) self->stream_.cancel();
      });
    }

   private:
    // Counts the request in pl_requests_in_progress from its header to its answer.
    void busy(bool now) {
      if (now != busy_) server_.metrics.requests_in_progress += now ? 1 : -1;
      busy_ = now;
    }

    void read() {
      busy(false);
      parser_.emplace();
      limit_parser(*parser_, server_.cfg.header_limit);
      // Idle between requests, then the read timeout once a request has begun.
      if (server_.stopping) return close();
      idle_ = true;
      stream_.expires_after(ms(first_ ? server_.cfg.read_timeout_s : server_.cfg.idle_timeout_s));
      http::async_read_header(stream_, buffer_, *parser_, beast::bind_front_handler(&Session::on_header, shared_from_this()));
    }

    void on_header(beast::error_code ec, std::size_t) {
      idle_ = false;
      if (ec) return fail_read(ec);
      busy(true);
      first_ = false;
      if (int status = admit_body(*parser_)) {
        linger_ = true;  // the client is still sending the body: let it finish so it reads the 413
        return reject(status, "the body is larger than this route accepts");
      }
      start_ = std::chrono::steady_clock::now();
      if (parser_->is_done()) return on_read({}, 0);  // no body (most GETs): no second read
      stream_.expires_after(ms(server_.cfg.read_timeout_s));
      http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&Session::on_read, shared_from_this()));
    }

    void fail_read(beast::error_code ec) {
      ReadFailure f = read_failure(ec);
      if (f.status == 0) return close();  // end of stream, timeout, reset: nothing to answer
      linger_ = f.linger;
      reject(f.status, f.message);
    }

    void on_read(beast::error_code ec, std::size_t) {
      if (ec) return fail_read(ec);
      auto& req = parser_->get();
      ApiRequest ar = to_api_request(std::move(req), next_request_id());
      ar.from_loopback = loopback_;
      bool keep = req.keep_alive() && !server_.stopping;
      ApiResponse r = server_.api.handle(ar);  // never throws
      request_id_ = ar.request_id;
      if (r.events && ar.method == "GET" && r.status == 200) return stream_events(r, req.version(), ar.method, ar.target);
      send(r, req.version(), keep, ar.method, ar.target);
    }

    void reject(int status, const std::string& message) {
      ApiResponse r = rejection(status, message);
      request_id_ = next_request_id();
      start_ = std::chrono::steady_clock::now();
      std::string method = parser_ && parser_->is_header_done() ? std::string(parser_->get().method_string()) : "-";
      std::string target = parser_ && parser_->is_header_done() ? std::string(parser_->get().target()) : "-";
      send(r, 11, false, method, target);
    }

    void send(ApiResponse& r, unsigned version, bool keep, const std::string& method, const std::string& target) {
      bool head = method == "HEAD";
      std::size_t size = r.blob ? r.blob->size() : r.body.size();
      log_answer(r, method, target, head ? 0 : size);
      // The header is written here, not built as a Beast response: its field container and the
      // stream it was printed through were a tenth of a tile GET's user-space time.
      write_header(r, version, keep, size);
      keep_ = keep;
      set_non_blocking();
      const int sock = stream_.socket().native_handle();
      if (r.blob && !head && r.status == 200 && size > kInlineBytes) {
        if (auto span = server_.blob_files.span_of(r.blob_hash, *r.blob)) {
          // A large tile from its file with sendfile(2): the header first, with MSG_MORE so that it
          // leaves in the same packets as the file's first bytes.
          file_fd_ = span->fd;
          file_off_ = span->offset;
          file_left_ = size;
          const ssize_t sent = ::send(sock, header_.data(), header_.size(), MSG_MORE | MSG_NOSIGNAL);
          if (sent == static_cast<ssize_t>(header_.size())) return send_file();
          if (sent < 0 && errno != EAGAIN && errno != EINTR) return close();
          const std::size_t done = sent > 0 ? static_cast<std::size_t>(sent) : 0;
          stream_.expires_after(ms(server_.cfg.read_timeout_s));
          net::async_write(stream_, net::buffer(header_.data() + done, header_.size() - done),
                           [self = shared_from_this()](beast::error_code ec, std::size_t) {
                             if (ec) return self->close();
                             self->send_file();
                           });
          return;
        }
      }
      // Anything else with its header in one sendmsg(2): one system call for the answer; copying a
      // tile of up to kInlineBytes into the socket costs less than a second call.
      if (r.blob) held_ = r.blob;
      else body_ = std::move(r.body);
      const std::string& body = r.blob ? *held_ : body_;
      const std::size_t body_bytes = head ? 0 : body.size();
      iovec parts[2] = {{header_.data(), header_.size()}, {const_cast<char*>(body.data()), body_bytes}};
      msghdr msg{};
      msg.msg_iov = parts;
      msg.msg_iovlen = body_bytes ? 2 : 1;
      const ssize_t sent = ::sendmsg(sock, &msg, MSG_NOSIGNAL);
      const std::size_t total = header_.size() + body_bytes;
      if (sent == static_cast<ssize_t>(total)) return after_answer();
      if (sent < 0 && errno != EAGAIN && errno != EINTR) return close();
      // The socket took part of it: the rest asynchronously, the bytes held until written.
      const std::size_t done = sent > 0 ? static_cast<std::size_t>(sent) : 0;
      if (done < header_.size()) {
        header_.append(body.data(), body_bytes);
        return write_rest(net::buffer(header_.data() + done, header_.size() - done));
      }
      write_rest(net::buffer(body.data() + (done - header_.size()), total - done));
    }

    // A Server-Sent Events answer (GET /v1/maps/{map}/events, viewer.cpp): the header, then the
    // records the vehicle hub queues on events_ as they come and a keep-alive comment every
    // EventStream::kKeepAliveSeconds, until the client leaves, the hub closes the stream (a client
    // too slow to read) or the server stops (drain). The body ends with the connection (no
    // Content-Length; Connection: close), which serves nothing else. It is written to the socket
    // itself, one write at a time, not through stream_, whose timeouts are for request and answer;
    // a read stays posted to notice the client leaving at once. Everything runs on the strand.
    void stream_events(ApiResponse& r, unsigned version, const std::string& method, const std::string& target) {
      log_answer(r, method, target, 0);
      events_ = std::move(r.events);
      write_header(r, version, false, 0, false);
      events_out_ = header_;
      stream_.expires_never();
      std::weak_ptr<Session> weak = weak_from_this();
      events_->set_wake([weak] {
        if (auto self = weak.lock()) net::post(self->stream_.get_executor(), [self] { self->flush_events(); });
      });
      watch_client();
      keep_alive();
      flush_events();
    }

    void flush_events() {
      if (events_writing_ || events_ended_) return;
      if (events_out_.empty()) events_out_ = events_->take();
      if (events_out_.empty()) {
        if (events_->closed()) end_events();
        return;
      }
      events_writing_ = true;
      events_write_start_ = std::chrono::steady_clock::now();
      net::async_write(stream_.socket(), net::buffer(events_out_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
        self->events_writing_ = false;
        self->events_out_.clear();
        if (ec) return self->end_events();
        self->flush_events();
      });
    }

    void keep_alive() {
      const auto period = std::chrono::seconds(EventStream::kKeepAliveSeconds);
      events_timer_.expires_after(period);
      events_timer_.async_wait([self = shared_from_this(), period](beast::error_code ec) {
        if (ec || self->events_ended_) return;
        // A write pending for a whole period: the client does not read. It may connect again.
        if (self->events_writing_ && std::chrono::steady_clock::now() - self->events_write_start_ >= period) return self->end_events();
        self->events_->push(": keep-alive\n\n");
        self->keep_alive();
      });
    }

    // The client sends nothing more after its request: a read ends when it leaves.
    void watch_client() {
      discard_.resize(4096);
      stream_.socket().async_read_some(net::buffer(discard_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
        if (ec) return self->end_events();
        self->watch_client();  // bytes after the request are ignored
      });
    }

    // Ends the stream: the pending read, write and timer complete with errors and the session goes.
    void end_events() {
      if (events_ended_) return;
      events_ended_ = true;
      events_->close();
      events_timer_.cancel();
      beast::error_code ec;
      stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
      stream_.socket().close(ec);
    }

    // The answer's metrics and access-log line.
    void log_answer(const ApiResponse& r, const std::string& method, const std::string& target, std::size_t bytes) {
      double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
      server_.metrics.observe(r.route.empty() ? "other" : r.route, r.status, seconds, bytes);
      if (server_.cfg.access_log)
        write_access_line(server_.cfg.api.log_json, request_id_, remote_, method, target, r.status, bytes, seconds);
    }

    // Tiles at most this large go out from memory with their header; larger ones with sendfile(2).
    // bench/bench_server.sh's tiles, pl-server against itself in alternating rounds: 3.4 KB tiles
    // inline 1.12-1.19x the requests/s of header + sendfile; 35 KB tiles inline 0.93x (median of
    // five rounds), so those stay with sendfile.
    static constexpr std::size_t kInlineBytes = 16 * 1024;

    // The response header into header_: status line, Server, Date, X-Request-Id, Content-Type, the
    // handler's fields (a field named twice keeps its last value, as Beast's set() did), Connection
    // where the version needs it, and Content-Length (the body's, also for HEAD; none for a status
    // that has no body, nor when `with_length` is false: a body that ends with the connection).
    void write_header(const ApiResponse& r, unsigned version, bool keep, std::size_t length, bool with_length = true) {
      std::string& h = header_;
      h.clear();
      h += version == 10 ? "HTTP/1.0 " : "HTTP/1.1 ";
      h += std::to_string(r.status);
      h += ' ';
      const auto reason = http::obsolete_reason(static_cast<http::status>(r.status));
      h.append(reason.data(), reason.size());
      h += "\r\nServer: pl-server\r\nDate: ";
      h += http_date();
      h += "\r\nX-Request-Id: ";
      h += request_id_;
      h += "\r\n";
      if (!r.content_type.empty()) {
        h += "Content-Type: ";
        h += r.content_type;
        h += "\r\n";
      }
      for (std::size_t i = 0; i < r.headers.size(); ++i) {
        const auto& [k, v] = r.headers[i];
        bool later = beast::iequals(k, "Content-Length") || beast::iequals(k, "Connection");
        for (std::size_t j = i + 1; j < r.headers.size() && !later; ++j) later = beast::iequals(k, r.headers[j].first);
        if (later) continue;
        h += k;
        h += ": ";
        h += v;
        h += "\r\n";
      }
      if (version == 10 && keep) h += "Connection: keep-alive\r\n";
      if (version != 10 && !keep) h += "Connection: close\r\n";
      const bool bodiless = r.status < 200 || r.status == 204 || r.status == 304;
      if (!bodiless && with_length) {
        h += "Content-Length: ";
        h += std::to_string(length);
        h += "\r\n";
      }
      h += "\r\n";
    }

    // The socket in non-blocking mode for our own sends, once per connection (each call is an
    // ioctl(2): one system call in five of a tile GET).
    void set_non_blocking() {
      if (non_blocking_) return;
      beast::error_code ec;
      stream_.socket().native_non_blocking(true, ec);
      non_blocking_ = !ec;
    }

    // An answer went out whole: the next request, a lingering close, or the end of the connection.
    void after_answer() {
      held_.reset();
      body_.clear();
      if (linger_) return linger();
      if (!keep_) return close();
      read();
    }

    void write_rest(net::const_buffer rest) {
      stream_.expires_after(ms(server_.cfg.read_timeout_s));
      net::async_write(stream_, rest, [self = shared_from_this()](beast::error_code ec, std::size_t) {
        if (ec) return self->close();
        self->after_answer();
      });
    }

    // The rest of the file, as fast as the socket takes it; waits for room without blocking a thread.
    void send_file() {
      auto sock = stream_.socket().native_handle();  // non-blocking since send()
      while (file_left_ > 0) {
        ssize_t n = ::sendfile(sock, file_fd_, &file_off_, file_left_);
        if (n > 0) {
          file_left_ -= static_cast<std::size_t>(n);
          continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && errno == EAGAIN) {
          // Wait until the socket takes more, for the read timeout at most.
          wait_timer_.expires_after(ms(server_.cfg.read_timeout_s));
          wait_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
            if (ec) return;  // cancelled: the socket became writable in time
            beast::error_code ignored;
            self->stream_.socket().cancel(ignored);
          });
          stream_.socket().async_wait(tcp::socket::wait_write, [self = shared_from_this()](beast::error_code ec) {
            self->wait_timer_.cancel();
            if (ec) return self->close();
            self->send_file();
          });
          return;
        }
        return close();  // the client went away
      }
      after_answer();
    }

    // Lingering close: stop sending, then read and drop what the client still sends (2 s at most),
    // so that a client busy writing a rejected body gets to read the answer instead of a reset.
    void linger() {
      beast::error_code ec;
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      stream_.expires_after(std::chrono::seconds(2));
      discard_.resize(64 * 1024);
      stream_.async_read_some(net::buffer(discard_), [self = shared_from_this()](beast::error_code e, std::size_t) {
        if (e) return;  // end of stream or timeout: the session ends
        self->linger_more();
      });
    }
    void linger_more() {
      stream_.async_read_some(net::buffer(discard_), [self = shared_from_this()](beast::error_code e, std::size_t) {
        if (!e) self->linger_more();
      });
    }

    void close() {
      beast::error_code ec;
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    }

    beast::tcp_stream stream_;
    beast::flat_buffer buffer_;
    std::optional<http::request_parser<http::string_body>> parser_;
    std::string body_;  // an answer's body while it is written
    std::shared_ptr<const std::string> held_;
    std::string header_;
    net::steady_timer wait_timer_{stream_.get_executor()};
    int file_fd_ = -1;
    off_t file_off_ = 0;
    std::size_t file_left_ = 0;
    bool keep_ = false;
    bool non_blocking_ = false;  // set_non_blocking() done
    Impl& server_;
    std::string remote_;
    bool loopback_ = false;  // the peer is this machine
    std::string request_id_;
    bool first_ = true;
    bool idle_ = false;
    bool busy_ = false;
    bool linger_ = false;
    std::vector<char> discard_;
    std::chrono::steady_clock::time_point start_;
    // An event stream's state (stream_events): set once the connection streams.
    std::shared_ptr<EventStream> events_;
    std::string events_out_;  // the bytes being written
    bool events_writing_ = false, events_ended_ = false;
    std::chrono::steady_clock::time_point events_write_start_;
    net::steady_timer events_timer_{stream_.get_executor()};
  };

  std::mutex sessions_mutex;
  std::map<Session*, std::weak_ptr<Session>> sessions;

  void accept(tcp::acceptor& acceptor) {
    acceptor.async_accept(net::make_strand(ioc), [this, &acceptor](beast::error_code ec, tcp::socket socket) {
      if (ec) {
        if (!stopping) accept(acceptor);
        return;
      }
      if (metrics.open_connections.load() >= cfg.max_connections) {
        // Over the limit: answer 503 at once and close.
        static const std::string body = "{\"error\":\"too many connections\",\"status\":503}\n";
        const std::string busy = "HTTP/1.1 503 Service Unavailable\r\nServer: pl-server\r\nDate: " + http_date() +
                                 "\r\nRetry-After: 1\r\nContent-Type: application/json\r\nConnection: close\r\n"
                                 "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
        beast::error_code wec;
        net::write(socket, net::buffer(busy), wec);
        socket.shutdown(tcp::socket::shutdown_both, wec);
      } else {
        beast::error_code oec;
        socket.set_option(tcp::no_delay(true), oec);  // request/response: no Nagle delay
        std::make_shared<Session>(std::move(socket), *this)->start();
      }
      if (!stopping) accept(acceptor);
    });
  }

  void begin_stop() {
    if (stopping.exchange(true)) return;
    api.set_draining(true);
    beast::error_code ec;
    for (auto& a : acceptors) a->close(ec);
    std::vector<std::shared_ptr<Session>> open;
    {
      std::lock_guard<std::mutex> lock(sessions_mutex);
      for (auto& [ptr, weak] : sessions)
        if (auto sp = weak.lock()) open.push_back(sp);
    }
    for (auto& sp : open) sp->drain();
    // In-flight requests finish (their connections close after the response); whatever is still
    // open after the drain timeout is cut.
    auto timer = std::make_shared<net::steady_timer>(ioc, ms(cfg.drain_timeout_s));
    timer->async_wait([this, timer](beast::error_code) { ioc.stop(); });
    poll_idle();
  }

  void poll_idle() {
    auto timer = std::make_shared<net::steady_timer>(ioc, std::chrono::milliseconds(20));
    timer->async_wait([this, timer](beast::error_code) {
      if (metrics.open_connections.load() == 0)
        ioc.stop();
      else
        poll_idle();
    });
  }
};

Server::Server(ServerConfig cfg) : impl_(std::make_unique<Impl>(std::move(cfg))) {
  // Tile bodies go out with sendfile(2), which, unlike Asio's sends (MSG_NOSIGNAL), raises SIGPIPE
  // when the client has gone: by default that ends the process. A client hanging up mid-answer is
  // an ordinary event (wrk at the end of a run did it every time): the write fails with EPIPE and
  // that connection is closed.
  std::signal(SIGPIPE, SIG_IGN);
}
Server::~Server() = default;

std::uint16_t Server::port() const { return impl_->acceptors.front()->local_endpoint().port(); }

std::vector<std::string> Server::addresses() const {
  std::vector<std::string> out;
  for (const auto& a : impl_->acceptors) {
    auto ep = a->local_endpoint();
    std::string host = ep.address().to_string();
    out.push_back((ep.address().is_v6() ? "[" + host + "]" : host) + ":" + std::to_string(ep.port()));
  }
  return out;
}

// The io_context's threads: a handler that throws (it should not) is logged and the thread goes
// on running, so one bad request never takes the server down.
static void run_guarded(net::io_context& ioc) {
  for (;;) {
    try {
      ioc.run();
      return;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "pl-server: unexpected error in a connection handler (the connection is dropped): %s\n", e.what());
    } catch (...) {
      std::fprintf(stderr, "pl-server: unexpected error in a connection handler (the connection is dropped)\n");
    }
  }
}

void Server::run() {
  impl_->signals.async_wait([this](beast::error_code ec, int) {
    if (!ec) impl_->begin_stop();
  });
  for (auto& a : impl_->acceptors) impl_->accept(*a);
  std::vector<std::thread> pool;
  for (int i = 1; i < std::max(1, impl_->cfg.threads); ++i) pool.emplace_back([this] { run_guarded(impl_->ioc); });
  run_guarded(impl_->ioc);
  for (auto& t : pool) t.join();
}

void Server::stop() {
  net::post(impl_->ioc, [this] { impl_->begin_stop(); });
}

}  // namespace pl::server
