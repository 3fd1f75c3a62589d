#include "dentar/haptics/usb_pedal.h"

#include <libusb-1.0/libusb.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>

namespace dentar::haptics {

const std::vector<PedalModel>& known_pedals() {
  static const std::vector<PedalModel> t = {
      {"vec", "VEC Infinity IN-USB-2 foot pedal", 0x05f3, 0x00ff, PedalModel::Kind::kHidBitmask, 0x7},
      {"pcsensor", "PCsensor FootSwitch (keyboard)", 0x0c45, 0x7403, PedalModel::Kind::kKeyboard, 0},
  };
  return t;
}

const PedalModel* find_pedal_model(std::uint16_t vid, std::uint16_t pid) {
  for (const auto& m : known_pedals())
    if (m.vid == vid && m.pid == pid) return &m;
  return nullptr;
}

const PedalModel* find_pedal_model(const std::string& id) {
  for (const auto& m : known_pedals())
    if (m.id == id) return &m;
  return nullptr;
}

std::optional<std::uint32_t> parse_bitmask_report(const std::uint8_t* b, std::size_t n) {
  if (!b || n != 2) return std::nullopt;
  return static_cast<std::uint32_t>(b[0]) | (static_cast<std::uint32_t>(b[1]) << 8);
}

bool parse_vid_pid(const std::string& s, std::uint16_t& vid, std::uint16_t& pid, std::string& error) {
  const auto colon = s.find(':');
  auto hex4 = [](const std::string& h, std::uint16_t& out) {
    if (h.empty() || h.size() > 4) return false;
    unsigned v = 0;
    for (char c : h) {
      if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
      v = v * 16 + static_cast<unsigned>(std::isdigit(static_cast<unsigned char>(c))
                                             ? c - '0'
                                             : std::tolower(static_cast<unsigned char>(c)) - 'a' + 10);
    }
    out = static_cast<std::uint16_t>(v);
    return true;
  };
  if (colon == std::string::npos || !hex4(s.substr(0, colon), vid) || !hex4(s.substr(colon + 1), pid)) {
    error = "'" + s + "' is not VID:PID in hex (for example 05f3:00ff)";
    return false;
  }
  return true;
}

std::string udev_rule_advice() {
  return "permission denied: install the udev rule: sudo cp assets/udev/70-dentar.rules "
         "/etc/udev/rules.d/ && sudo udevadm control --reload && sudo udevadm trigger, then "
         "unplug and replug the device (README, \"Connect your devices\")";
}

void PedalPublisher::set_disconnected(const std::string& why) {
  down_.store(false, std::memory_order_release);
  connected_.store(false, std::memory_order_release);
  std::lock_guard<std::mutex> l(mu_);
  status_ = why;
}

void PedalPublisher::set_connected(const std::string& what) {
  {
    std::lock_guard<std::mutex> l(mu_);
    status_ = what;
  }
  connected_.store(true, std::memory_order_release);
}

std::string PedalPublisher::status() const {
  std::string s;
  {
    std::lock_guard<std::mutex> l(mu_);
    s = status_;
  }
  if (connected()) s += pressed() ? " (pressed)" : " (released)";
  return s;
}

struct UsbPedal::Impl {
  libusb_context* ctx = nullptr;
  libusb_device_handle* h = nullptr;
  libusb_hotplug_callback_handle cb = 0;
  bool cb_registered = false;
  std::atomic<bool> arrived{true};  // try to open at start
  unsigned char ep = 0;
  int iface = 0;
  int max_packet = 8;

  static int LIBUSB_CALL on_hotplug(libusb_context*, libusb_device*, libusb_hotplug_event ev,
                                    void* user) {
    auto* self = static_cast<Impl*>(user);
    if (ev == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED) self->arrived.store(true);
    return 0;  // stay registered
  }
  void close() {
    if (h) {
      libusb_release_interface(h, iface);
      libusb_close(h);
    }
    h = nullptr;
  }
};

Result<std::unique_ptr<UsbPedal>> UsbPedal::open(std::uint16_t vid, std::uint16_t pid,
                                                 std::uint32_t drill_mask, std::string name) {
  std::unique_ptr<UsbPedal> p(new UsbPedal());
  p->vid_ = vid;
  p->pid_ = pid;
  p->mask_ = drill_mask;
  char id[16];
  std::snprintf(id, sizeof id, "%04x:%04x", vid, pid);
  if (name.empty()) {
    const PedalModel* m = find_pedal_model(vid, pid);
    name = "USB pedal " + std::string(id) + (m ? " (" + m->name + ")" : "");
  }
  p->name_ = std::move(name);
  p->impl_ = std::make_unique<Impl>();
  if (int rc = libusb_init(&p->impl_->ctx); rc != 0)
    return Error{"libusb cannot start: " + std::string(libusb_error_name(rc))};
  if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
    const int rc = libusb_hotplug_register_callback(
        p->impl_->ctx, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED, LIBUSB_HOTPLUG_NO_FLAGS, vid, pid,
        LIBUSB_HOTPLUG_MATCH_ANY, &Impl::on_hotplug, p->impl_.get(), &p->impl_->cb);
    p->impl_->cb_registered = rc == LIBUSB_SUCCESS;
  }
  p->hotplug_ = p->impl_->cb_registered;
  p->pub_.set_disconnected("not found yet (waiting for it to be plugged in)");
  p->thread_ = std::thread([raw = p.get()] { raw->run(); });
  return p;
}

UsbPedal::~UsbPedal() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  if (impl_) {
    impl_->close();
    if (impl_->cb_registered) libusb_hotplug_deregister_callback(impl_->ctx, impl_->cb);
    if (impl_->ctx) libusb_exit(impl_->ctx);
  }
}

void UsbPedal::run() {
  Impl& m = *impl_;
  auto try_open = [&]() {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(m.ctx, &list);
    std::string why = "not plugged in";
    for (ssize_t i = 0; i < n && !m.h; ++i) {
      libusb_device_descriptor dd;
      if (libusb_get_device_descriptor(list[i], &dd) != 0 || dd.idVendor != vid_ || dd.idProduct != pid_)
        continue;
      libusb_device_handle* h = nullptr;
      const int rc = libusb_open(list[i], &h);
      if (rc == LIBUSB_ERROR_ACCESS) {
        why = udev_rule_advice();
        continue;
      }
      if (rc != 0) {
        why = std::string("cannot open: ") + libusb_error_name(rc);
        continue;
      }
      // Interface 0's first interrupt IN endpoint.
      libusb_config_descriptor* cfg = nullptr;
      unsigned char ep = 0;
      int packet = 8;
      if (libusb_get_active_config_descriptor(list[i], &cfg) == 0 && cfg->bNumInterfaces > 0 &&
          cfg->interface[0].num_altsetting > 0) {
        const libusb_interface_descriptor& alt = cfg->interface[0].altsetting[0];
        for (int e = 0; e < alt.bNumEndpoints; ++e) {
          const libusb_endpoint_descriptor& d = alt.endpoint[e];
          if ((d.bEndpointAddress & LIBUSB_ENDPOINT_IN) &&
              (d.bmAttributes & 3) == LIBUSB_TRANSFER_TYPE_INTERRUPT) {
            ep = d.bEndpointAddress;
            packet = d.wMaxPacketSize;
            break;
          }
        }
      }
      if (cfg) libusb_free_config_descriptor(cfg);
      if (!ep) {
        why = "no interrupt IN endpoint on interface 0: not a HID pedal";
        libusb_close(h);
        continue;
      }
      libusb_set_auto_detach_kernel_driver(h, 1);
      if (const int c = libusb_claim_interface(h, 0); c != 0) {
        why = c == LIBUSB_ERROR_BUSY ? "another program holds the pedal (close it)"
                                     : std::string("cannot claim it: ") + libusb_error_name(c);
        libusb_close(h);
        continue;
      }
      m.h = h;
      m.ep = ep;
      m.iface = 0;
      m.max_packet = std::max(1, std::min(packet, 64));
    }
    if (list) libusb_free_device_list(list, 1);
    if (m.h)
      pub_.set_connected("connected" + std::string(hotplug_ ? "" : " (no hot-plug: polling)"));
    else
      pub_.set_disconnected(why);
  };

  auto last_poll = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  unsigned char buf[64];
  while (!stop_.load(std::memory_order_acquire)) {
    if (!m.h) {
      if (m.cb_registered) {
        timeval tv{0, 50000};
        libusb_handle_events_timeout_completed(m.ctx, &tv, nullptr);
        if (m.arrived.exchange(false)) try_open();
      } else if (std::chrono::steady_clock::now() - last_poll > std::chrono::milliseconds(250)) {
        last_poll = std::chrono::steady_clock::now();
        try_open();
      } else {
        usleep(20000);
      }
      continue;
    }
    int got = 0;
    // 5 ms: an unplug or a stop request is seen within that.
    const int rc = libusb_interrupt_transfer(m.h, m.ep, buf, m.max_packet, &got, 5);
    if (rc == 0) {
      // The VEC pedal sends exactly 2 bytes; other HID bitmask pedals may pad
      // their report: the first two bytes carry the bits.
      const auto bits = parse_bitmask_report(buf, got >= 2 ? 2 : static_cast<std::size_t>(got));
      if (bits) {
        const bool down = (*bits & mask_) != 0;
        if (down != pub_.pressed()) pub_.count_change();
        pub_.set_down(down);
      }
    } else if (rc == LIBUSB_ERROR_TIMEOUT) {
      // No change: HID pedals report on press and release only.
    } else {
      pub_.set_disconnected(rc == LIBUSB_ERROR_NO_DEVICE
                                ? "unplugged (drill stopped); waiting for it to come back"
                                : std::string("read error ") + libusb_error_name(rc) +
                                      " (drill stopped); reopening");
      m.close();
    }
  }
  pub_.set_disconnected("closed");
}

std::vector<UsbDeviceEntry> list_usb_devices(bool all, std::string& error) {
  std::vector<UsbDeviceEntry> out;
  libusb_context* ctx = nullptr;
  if (int rc = libusb_init(&ctx); rc != 0) {
    error = std::string("libusb cannot start: ") + libusb_error_name(rc);
    return out;
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx, &list);
  if (n < 0) error = std::string("cannot list USB devices: ") + libusb_error_name(static_cast<int>(n));
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor dd;
    if (libusb_get_device_descriptor(list[i], &dd) != 0) continue;
    const PedalModel* m = find_pedal_model(dd.idVendor, dd.idProduct);
    if (!m && !all) continue;
    UsbDeviceEntry e;
    e.vid = dd.idVendor;
    e.pid = dd.idProduct;
    e.bus = libusb_get_bus_number(list[i]);
    e.address = libusb_get_device_address(list[i]);
    char path[64];
    std::snprintf(path, sizeof path, "/dev/bus/usb/%03d/%03d", e.bus, e.address);
    e.path = path;
    e.accessible = access(path, R_OK | W_OK) == 0;
    e.known_as = m ? m->id : "";
    if (!e.accessible) e.message = udev_rule_advice();
    out.push_back(e);
  }
  if (list) libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return out;
}

}  // namespace dentar::haptics
