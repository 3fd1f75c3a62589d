#include "dentar/haptics/evdev_pedal.h"

#include <fcntl.h>
#include <linux/input.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dentar::haptics {
namespace {

struct KeyName {
  const char* name;
  int code;
};
#define DENTAR_K(k) {#k, k}
const KeyName kKeys[] = {
    DENTAR_K(KEY_A), DENTAR_K(KEY_B), DENTAR_K(KEY_C), DENTAR_K(KEY_D), DENTAR_K(KEY_E),
    DENTAR_K(KEY_F), DENTAR_K(KEY_G), DENTAR_K(KEY_H), DENTAR_K(KEY_I), DENTAR_K(KEY_J),
    DENTAR_K(KEY_K), DENTAR_K(KEY_L), DENTAR_K(KEY_M), DENTAR_K(KEY_N), DENTAR_K(KEY_O),
    DENTAR_K(KEY_P), DENTAR_K(KEY_Q), DENTAR_K(KEY_R), DENTAR_K(KEY_S), DENTAR_K(KEY_T),
    DENTAR_K(KEY_U), DENTAR_K(KEY_V), DENTAR_K(KEY_W), DENTAR_K(KEY_X), DENTAR_K(KEY_Y),
    DENTAR_K(KEY_Z), DENTAR_K(KEY_1), DENTAR_K(KEY_2), DENTAR_K(KEY_3), DENTAR_K(KEY_4),
    DENTAR_K(KEY_5), DENTAR_K(KEY_6), DENTAR_K(KEY_7), DENTAR_K(KEY_8), DENTAR_K(KEY_9),
    DENTAR_K(KEY_0), DENTAR_K(KEY_SPACE), DENTAR_K(KEY_ENTER), DENTAR_K(KEY_TAB),
    DENTAR_K(KEY_ESC), DENTAR_K(KEY_LEFTCTRL), DENTAR_K(KEY_RIGHTCTRL), DENTAR_K(KEY_LEFTSHIFT),
    DENTAR_K(KEY_RIGHTSHIFT), DENTAR_K(KEY_LEFTALT), DENTAR_K(KEY_RIGHTALT), DENTAR_K(KEY_UP),
    DENTAR_K(KEY_DOWN), DENTAR_K(KEY_LEFT), DENTAR_K(KEY_RIGHT), DENTAR_K(KEY_PAGEUP),
    DENTAR_K(KEY_PAGEDOWN), DENTAR_K(KEY_F1), DENTAR_K(KEY_F2), DENTAR_K(KEY_F3),
    DENTAR_K(KEY_F4), DENTAR_K(KEY_F5), DENTAR_K(KEY_F6), DENTAR_K(KEY_F7), DENTAR_K(KEY_F8),
    DENTAR_K(KEY_F9), DENTAR_K(KEY_F10), DENTAR_K(KEY_F11), DENTAR_K(KEY_F12),
    DENTAR_K(BTN_LEFT), DENTAR_K(BTN_RIGHT), DENTAR_K(BTN_MIDDLE),
};
#undef DENTAR_K

std::string read_line(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::string s;
  std::getline(f, s);
  return s;
}

}  // namespace

Result<std::vector<int>> parse_key_map(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    while (!item.empty() && item.front() == ' ') item.erase(item.begin());
    while (!item.empty() && item.back() == ' ') item.pop_back();
    if (item.empty()) continue;
    bool found = false;
    for (const KeyName& k : kKeys)
      if (item == k.name) {
        out.push_back(k.code);
        found = true;
        break;
      }
    if (found) continue;
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (end && *end == '\0' && v > 0 && v <= KEY_MAX) {
      out.push_back(static_cast<int>(v));
      continue;
    }
    return Error{"key map: unknown key '" + item +
                 "': use names such as KEY_B, KEY_LEFTCTRL, BTN_LEFT or a decimal evdev code"};
  }
  return out;
}

std::string find_event_node(std::uint16_t vid, std::uint16_t pid, const std::string& sysfs_input) {
  namespace fs = std::filesystem;
  std::error_code ec;
  char want_v[8], want_p[8];
  std::snprintf(want_v, sizeof want_v, "%04x", vid);
  std::snprintf(want_p, sizeof want_p, "%04x", pid);
  for (const auto& e : fs::directory_iterator(sysfs_input, ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("event", 0) != 0) continue;
    if (read_line(e.path() / "device/id/vendor") == want_v &&
        read_line(e.path() / "device/id/product") == want_p)
      return "/dev/input/" + n;
  }
  return {};
}

Result<std::unique_ptr<EvdevPedal>> EvdevPedal::open(const std::string& path, std::vector<int> keys,
                                                     std::uint16_t vid, std::uint16_t pid,
                                                     std::string name) {
  std::unique_ptr<EvdevPedal> p(new EvdevPedal());
  p->path_ = path;
  p->keys_ = std::move(keys);
  if (vid == 0 && pid == 0) {
    // Remember the device's USB identity, so it is found again after an
    // unplug even when it comes back as another eventN.
    namespace fs = std::filesystem;
    const fs::path id = fs::path("/sys/class/input") / fs::path(path).filename() / "device/id";
    const std::string v = read_line(id / "vendor"), d = read_line(id / "product");
    if (!v.empty() && !d.empty()) {
      vid = static_cast<std::uint16_t>(std::strtoul(v.c_str(), nullptr, 16));
      pid = static_cast<std::uint16_t>(std::strtoul(d.c_str(), nullptr, 16));
    }
  }
  p->vid_ = vid;
  p->pid_ = pid;
  p->can_reopen_ = true;
  p->name_ = name.empty() ? "keyboard pedal " + path : std::move(name);
  p->down_.assign(KEY_MAX + 1, 0);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    if (e == EACCES || e == EPERM) return Error{p->name_ + ": " + udev_rule_advice()};
    return Error{p->name_ + ": cannot open " + path + ": " + std::strerror(e) +
                 (e == ENOENT ? " (is the pedal plugged in? `dentar devices` lists pedals)" : "")};
  }
  ioctl(fd, EVIOCGRAB, 1);  // keep its keys out of the window; not fatal if refused
  p->fd_ = fd;
  p->pub_.set_connected("connected at " + path);
  p->thread_ = std::thread([raw = p.get()] { raw->run(); });
  return p;
}

std::unique_ptr<EvdevPedal> EvdevPedal::from_fd(int fd, std::vector<int> keys, std::string name) {
  std::unique_ptr<EvdevPedal> p(new EvdevPedal());
  p->keys_ = std::move(keys);
  p->name_ = std::move(name);
  p->down_.assign(KEY_MAX + 1, 0);
  p->fd_ = fd;
  p->pub_.set_connected("connected");
  p->thread_ = std::thread([raw = p.get()] { raw->run(); });
  return p;
}

EvdevPedal::~EvdevPedal() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) ::close(fd_);
}

bool EvdevPedal::reopen() {
  const std::string path = (vid_ || pid_) ? find_event_node(vid_, pid_) : path_;
  if (path.empty()) return false;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == EACCES || errno == EPERM) pub_.set_disconnected(udev_rule_advice());
    return false;
  }
  ioctl(fd, EVIOCGRAB, 1);
  fd_ = fd;
  held_ = 0;
  std::fill(down_.begin(), down_.end(), 0);
  pub_.set_connected("connected at " + path + " (reconnected)");
  return true;
}

void EvdevPedal::run() {
  auto last_try = std::chrono::steady_clock::now();
  input_event ev[64];
  auto unplug = [&](const std::string& why) {
    pub_.set_disconnected(why);
    ::close(fd_);
    fd_ = -1;
    held_ = 0;
    std::fill(down_.begin(), down_.end(), 0);
  };
  while (!stop_.load(std::memory_order_acquire)) {
    if (fd_ < 0) {
      if (!can_reopen_) break;
      if (std::chrono::steady_clock::now() - last_try > std::chrono::milliseconds(250)) {
        last_try = std::chrono::steady_clock::now();
        reopen();
      } else {
        usleep(20000);
      }
      continue;
    }
    pollfd pfd{fd_, POLLIN, 0};
    const int pr = poll(&pfd, 1, 5);  // 5 ms: sees a stop request within that
    if (pr <= 0) continue;
    const ssize_t n = ::read(fd_, ev, sizeof ev);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      unplug(std::string("unplugged (") + std::strerror(errno) + "); drill stopped");
      continue;
    }
    if (n == 0) {
      unplug("unplugged (end of events); drill stopped");
      continue;
    }
    const std::size_t count = static_cast<std::size_t>(n) / sizeof(input_event);
    for (std::size_t i = 0; i < count; ++i) {
      const input_event& e = ev[i];
      if (e.type == EV_SYN && e.code == SYN_DROPPED) {  // lost events: be safe, release
        held_ = 0;
        std::fill(down_.begin(), down_.end(), 0);
        continue;
      }
      if (e.type != EV_KEY || e.code > KEY_MAX || e.value == 2) continue;  // 2 = autorepeat
      bool mapped = keys_.empty();
      for (int k : keys_) mapped |= k == e.code;
      if (!mapped) continue;
      unsigned char& d = down_[e.code];
      if (e.value == 1 && !d) {
        d = 1;
        ++held_;
      } else if (e.value == 0 && d) {
        d = 0;
        --held_;
      }
    }
    const bool down = held_ > 0;
    if (down != pub_.pressed()) pub_.count_change();
    pub_.set_down(down);
  }
  if (fd_ >= 0 && !stop_.load()) pub_.set_disconnected("closed");
}

}  // namespace dentar::haptics
