#include "front.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <openssl/err.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace dentar::store {
namespace {

using Clock = std::chrono::steady_clock;

Clock::time_point after(double s) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

struct Conn {
  int fd = -1;
  SSL* ssl = nullptr;
  bool handshaken = false;
  std::string ip;
  int port = 0;
  std::string buf;          // bytes received and not yet served
  std::size_t request = 0;  // length of the complete request at buf's start (0: not yet)
  Clock::time_point deadline;
  int served = 0;
  short want = POLLIN;  // what the TLS layer waits for
};

bool iequal_prefix(const std::string& s, std::size_t at, const char* name) {
  const std::size_t n = std::strlen(name);
  if (s.size() < at + n) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (std::tolower(static_cast<unsigned char>(s[at + i])) != name[i]) return false;
  return true;
}

// The worker's view of one buffered request: reads come from memory, writes
// go to the socket with a deadline (the socket is non-blocking).
class BufferStream final : public httplib::Stream {
 public:
  BufferStream(Conn& c, double write_timeout_s) : c_(c), write_deadline_(after(write_timeout_s)) {}
  bool is_readable() const override { return pos_ < c_.request; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    const std::size_t n = std::min(size, c_.request - pos_);
    std::memcpy(ptr, c_.buf.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    std::size_t done = 0;
    while (done < size) {
      ssize_t n;
      short wait = POLLOUT;
      if (c_.ssl) {
        const int r = SSL_write(c_.ssl, ptr + done, static_cast<int>(std::min<std::size_t>(size - done, 1 << 30)));
        n = r;
        if (r <= 0) {
          const int e = SSL_get_error(c_.ssl, r);
          if (e == SSL_ERROR_WANT_READ) wait = POLLIN;
          else if (e != SSL_ERROR_WANT_WRITE) return -1;
        }
      } else {
        n = ::send(c_.fd, ptr + done, size - done, MSG_NOSIGNAL);
        if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return -1;
      }
      if (n > 0) {
        done += static_cast<std::size_t>(n);
        continue;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(write_deadline_ - Clock::now()).count();
      if (left <= 0) return -1;  // a client that does not read its answer
      pollfd p{c_.fd, wait, 0};
      if (::poll(&p, 1, static_cast<int>(left)) < 0 && errno != EINTR) return -1;
    }
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.ip;
    port = c_.port;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    ip.clear();
    port = 0;
    if (::getsockname(c_.fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return;
    char host[NI_MAXHOST], serv[NI_MAXSERV];
    if (::getnameinfo(reinterpret_cast<sockaddr*>(&a), len, host, sizeof host, serv, sizeof serv,
                      NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
      ip = host;
      port = std::atoi(serv);
    }
  }
  socket_t socket() const override { return c_.fd; }
  std::size_t consumed() const { return pos_; }

 private:
  Conn& c_;
  std::size_t pos_ = 0;
  Clock::time_point write_deadline_;
};

}  // namespace

struct Front::Impl {
  FrontOptions opt;
  FrontHandler handler;
  int listen_fd = -1, wake_fd = -1, port = 0;
  std::atomic<bool> stopping{false};

  std::mutex mu;  // guards ready, returned, per_ip, open
  std::condition_variable ready_cv;
  std::deque<Conn*> ready;     // complete requests for the workers
  std::vector<Conn*> returned; // kept-alive connections back from the workers
  std::map<std::string, int> per_ip;
  int open = 0;
  std::map<std::string, Clock::time_point> last_busy_log;

  void log(const std::string& line) {
    if (opt.log) opt.log(line);
  }
  void wake() {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(wake_fd, &one, sizeof one);
  }

  void close_conn(Conn* c) {
    if (c->ssl) {
      if (c->handshaken) SSL_shutdown(c->ssl);  // one close_notify, no waiting
      SSL_free(c->ssl);
    }
    ::close(c->fd);
    {
      std::lock_guard lk(mu);
      if (--per_ip[c->ip] <= 0) per_ip.erase(c->ip);
      --open;
    }
    delete c;
  }

  // A short answer from the front itself, best effort (the socket is
  // non-blocking and about to close).
  void refuse(Conn* c, int status, const char* reason, const std::string& why) {
    log(c->ip + ": " + why + "; answered " + std::to_string(status) + " and closed");
    const std::string body = std::to_string(status) + " " + reason + "\n";
    const std::string msg = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                            "\r\nContent-Type: text/plain\r\nConnection: close\r\nContent-Length: " +
                            std::to_string(body.size()) + "\r\n\r\n" + body;
    if (c->ssl) {
      if (c->handshaken) (void)SSL_write(c->ssl, msg.data(), static_cast<int>(msg.size()));
    } else {
      (void)::send(c->fd, msg.data(), msg.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    ::shutdown(c->fd, SHUT_WR);
    close_conn(c);
  }

  // Reads what is there. false: the connection is gone (closed already).
  bool read_some(Conn* c) {
    char tmp[16384];
    const std::size_t cap = opt.max_header_bytes + opt.max_body_bytes + sizeof tmp;
    while (c->buf.size() < cap) {
      if (c->ssl && !c->handshaken) {
        const int r = SSL_accept(c->ssl);
        if (r == 1) {
          c->handshaken = true;
          c->want = POLLIN;
          continue;
        }
        const int e = SSL_get_error(c->ssl, r);
        if (e == SSL_ERROR_WANT_READ) c->want = POLLIN;
        else if (e == SSL_ERROR_WANT_WRITE) c->want = POLLOUT;
        else {
          ERR_clear_error();
          close_conn(c);  // not TLS, or a failed handshake
          return false;
        }
        return true;
      }
      ssize_t n;
      if (c->ssl) {
        const int r = SSL_read(c->ssl, tmp, sizeof tmp);
        if (r > 0) n = r;
        else {
          const int e = SSL_get_error(c->ssl, r);
          if (e == SSL_ERROR_WANT_READ || e == SSL_ERROR_WANT_WRITE) {
            c->want = e == SSL_ERROR_WANT_READ ? POLLIN : POLLOUT;
            return true;
          }
          ERR_clear_error();
          close_conn(c);
          return false;
        }
      } else {
        n = ::recv(c->fd, tmp, sizeof tmp, 0);
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return true;
        if (n <= 0) {
          close_conn(c);
          return false;
        }
      }
      c->buf.append(tmp, static_cast<std::size_t>(n));
    }
    return true;
  }

  // Is a whole request in? true: handed to a worker or refused (c is gone).
  bool complete(Conn* c) {
    // Empty lines before a request line are allowed (RFC 9112 2.2).
    std::size_t lead = 0;
    while (lead + 1 < c->buf.size() && c->buf[lead] == '\r' && c->buf[lead + 1] == '\n') lead += 2;
    if (lead) c->buf.erase(0, lead);
    const std::size_t end = c->buf.find("\r\n\r\n");
    const std::size_t head_len = end == std::string::npos ? c->buf.size() : end + 4;
    std::size_t lines = 0;
    for (std::size_t p = c->buf.find('\n'); p != std::string::npos && p < head_len; p = c->buf.find('\n', p + 1)) ++lines;
    if (head_len > opt.max_header_bytes || lines > opt.max_headers + 2) {
      refuse(c, 431, "Request Header Fields Too Large",
             "request head over " + std::to_string(opt.max_header_bytes) + " bytes or " + std::to_string(opt.max_headers) +
                 " headers");
      return true;
    }
    if (end == std::string::npos) return false;
    std::size_t body = 0;
    bool has_length = false;
    for (std::size_t p = c->buf.find("\r\n") + 2; p < end; p = c->buf.find("\r\n", p) + 2) {
      if (iequal_prefix(c->buf, p, "transfer-encoding:")) {
        refuse(c, 411, "Length Required", "a request body without Content-Length");
        return true;
      }
      if (iequal_prefix(c->buf, p, "content-length:")) {
        std::size_t q = p + 15;
        while (q < end && (c->buf[q] == ' ' || c->buf[q] == '\t')) ++q;
        std::size_t v = 0, digits = 0;
        for (; q < end && std::isdigit(static_cast<unsigned char>(c->buf[q])) && digits < 12; ++q, ++digits)
          v = v * 10 + static_cast<std::size_t>(c->buf[q] - '0');
        if (digits == 0 || has_length) {
          refuse(c, 400, "Bad Request", "a bad or repeated Content-Length");
          return true;
        }
        has_length = true;
        body = v;
      }
    }
    if (body > opt.max_body_bytes) {
      refuse(c, 413, "Payload Too Large", "a body of " + std::to_string(body) + " bytes");
      return true;
    }
    if (c->buf.size() < head_len + body) return false;
    c->request = head_len + body;
    {
      std::lock_guard lk(mu);
      ready.push_back(c);
    }
    ready_cv.notify_one();
    return true;
  }

  void accept_all(std::vector<Conn*>& polled) {
    for (;;) {
      sockaddr_storage a{};
      socklen_t len = sizeof a;
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&a), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;  // EAGAIN, or out of descriptors: the next poll round
      auto* c = new Conn();
      c->fd = fd;
      char host[NI_MAXHOST], serv[NI_MAXSERV];
      if (::getnameinfo(reinterpret_cast<sockaddr*>(&a), len, host, sizeof host, serv, sizeof serv,
                        NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
        c->ip = host;
        c->port = std::atoi(serv);
      }
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      c->deadline = after(opt.request_timeout_s);
      bool over_ip = false, over_all = false;
      {
        std::lock_guard lk(mu);
        over_ip = ++per_ip[c->ip] > opt.max_conn_per_client;
        over_all = ++open > opt.max_connections;
      }
      if (over_ip || over_all) {
        // One log line per address per 10 s: a flood must not flood the log.
        const auto now = Clock::now();
        if (last_busy_log.size() > 10000) last_busy_log.clear();
        auto& last = last_busy_log[c->ip];
        if (now - last > std::chrono::seconds(10)) {
          last = now;
          log(c->ip + ": " + (over_ip ? "more than " + std::to_string(opt.max_conn_per_client) + " connections from this address"
                                      : "more than " + std::to_string(opt.max_connections) + " connections in all") +
              "; new ones are answered 503 and closed");
        }
        const char* msg = "HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
        if (!opt.tls) (void)::send(fd, msg, std::strlen(msg), MSG_NOSIGNAL | MSG_DONTWAIT);
        close_conn(c);
        continue;
      }
      if (opt.tls) {
        c->ssl = SSL_new(opt.tls);
        if (!c->ssl) {
          close_conn(c);
          continue;
        }
        SSL_set_fd(c->ssl, fd);
      }
      polled.push_back(c);
    }
  }

  void worker() {
    for (;;) {
      Conn* c = nullptr;
      {
        std::unique_lock lk(mu);
        ready_cv.wait(lk, [&] { return stopping.load() || !ready.empty(); });
        if (ready.empty()) return;
        c = ready.front();
        ready.pop_front();
      }
      bool close = false;
      const bool last = c->served + 1 >= opt.keep_alive_max;
      BufferStream s(*c, opt.write_timeout_s);
      bool ok = false;
      try {
        ok = handler(s, last, close);
      } catch (...) {
        ok = false;
      }
      c->buf.erase(0, c->request);
      c->request = 0;
      ++c->served;
      if (!ok || close || last || stopping) {
        close_conn(c);
        continue;
      }
      c->deadline = after(opt.request_timeout_s);
      {
        std::lock_guard lk(mu);
        returned.push_back(c);
      }
      wake();
    }
  }

  Status run() {
    std::vector<std::thread> workers;
    for (int i = 0; i < opt.workers; ++i) workers.emplace_back([this] { worker(); });
    std::vector<Conn*> polled;
    std::vector<pollfd> fds;
    while (!stopping) {
      std::vector<Conn*> back;
      {
        std::lock_guard lk(mu);
        back.swap(returned);
      }
      // A kept-alive connection may already hold its next request. (Only
      // these are looked at here: rescanning every waiting head on every
      // wake-up would let many slow clients burn the loop's CPU.)
      for (Conn* c : back)
        if (c->buf.empty() || !complete(c)) polled.push_back(c);
      fds.assign({{listen_fd, POLLIN, 0}, {wake_fd, POLLIN, 0}});
      auto next = Clock::now() + std::chrono::seconds(1);
      for (Conn* c : polled) {
        fds.push_back({c->fd, c->want, 0});
        next = std::min(next, c->deadline);
      }
      const auto ms = std::max<long long>(
          0, std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now()).count() + 1);
      if (::poll(fds.data(), fds.size(), static_cast<int>(ms)) < 0 && errno != EINTR) break;
      if (fds[1].revents & POLLIN) {
        std::uint64_t v;
        [[maybe_unused]] const ssize_t n = ::read(wake_fd, &v, sizeof v);
      }
      std::vector<Conn*> keep;
      keep.reserve(polled.size());
      const auto now = Clock::now();
      for (std::size_t i = 0; i < polled.size(); ++i) {
        Conn* c = polled[i];
        const short ev = fds[i + 2].revents;
        if (ev & (POLLIN | POLLOUT | POLLHUP | POLLERR)) {
          if (!read_some(c)) continue;
          if (complete(c)) continue;
        }
        if (now >= c->deadline) {
          if (c->buf.empty() && c->served > 0) {
            close_conn(c);  // an idle kept-alive connection: close quietly
          } else {
            refuse(c, 408, "Request Timeout",
                   "the request was not complete within " + std::to_string(static_cast<int>(opt.request_timeout_s)) +
                       " s (" + std::to_string(c->buf.size()) + " bytes in; a slow or stalled client)");
          }
          continue;
        }
        keep.push_back(c);
      }
      polled.swap(keep);
      if (fds[0].revents & POLLIN) accept_all(polled);
    }
    stopping = true;
    ready_cv.notify_all();
    for (auto& t : workers) t.join();
    for (Conn* c : polled) close_conn(c);
    for (Conn* c : returned) close_conn(c);
    returned.clear();
    for (Conn* c : ready) close_conn(c);
    ready.clear();
    return {};
  }
};

Front::Front(FrontOptions opt, FrontHandler handler) : impl_(std::make_unique<Impl>()) {
  impl_->opt = std::move(opt);
  impl_->handler = std::move(handler);
  impl_->wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
}

Front::~Front() {
  if (impl_->listen_fd >= 0) ::close(impl_->listen_fd);
  if (impl_->wake_fd >= 0) ::close(impl_->wake_fd);
}

Status Front::bind() {
  auto& m = *impl_;
  addrinfo hints{}, *res = nullptr;
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  const std::string port = std::to_string(m.opt.port);
  if (::getaddrinfo(m.opt.host.c_str(), port.c_str(), &hints, &res) != 0 || !res)
    return Error{m.opt.host + ": not an address to listen on"};
  int fd = -1;
  for (addrinfo* a = res; a && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) != 0 || ::listen(fd, 256) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(res);
  if (fd < 0) return Error{m.opt.host + ":" + port + ": cannot listen (port in use? another --port)"};
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  m.port = ntohs(a.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&a)->sin6_port
                                         : reinterpret_cast<sockaddr_in*>(&a)->sin_port);
  m.listen_fd = fd;
  return {};
}

int Front::port() const { return impl_->port; }

Status Front::run() {
  if (impl_->listen_fd < 0) return Error{"the server is not bound to a port"};
  return impl_->run();
}

void Front::stop() {
  impl_->stopping = true;
  impl_->wake();
}

}  // namespace dentar::store
