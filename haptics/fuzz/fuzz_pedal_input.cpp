// Fuzz target: the pedal input parsers (device and command-line input):
// HID bitmask reports, VID:PID words and evdev key maps. The first byte picks
// the parser, the rest is its input. They must accept or refuse with a
// message naming the input, never crash; accepted values must be consistent.
#include <linux/input.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dentar/haptics/evdev_pedal.h"
#include "dentar/haptics/usb_pedal.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::haptics;
  if (size == 0) return 0;
  const std::uint8_t* in = data + 1;
  const std::size_t n = size - 1;
  const std::string text(reinterpret_cast<const char*>(in), n);
  switch (data[0] % 3) {
    case 0: {
      const auto bits = parse_bitmask_report(in, n);
      if (bits.has_value() != (n == 2)) std::abort();
      if (bits && *bits != (static_cast<std::uint32_t>(in[0]) | (static_cast<std::uint32_t>(in[1]) << 8)))
        std::abort();
      break;
    }
    case 1: {
      std::uint16_t v = 0, p = 0;
      std::string err;
      if (parse_vid_pid(text, v, p, err)) {
        char again[16];
        std::snprintf(again, sizeof again, "%04x:%04x", v, p);
        std::uint16_t v2 = 0, p2 = 0;
        if (!parse_vid_pid(again, v2, p2, err) || v2 != v || p2 != p) std::abort();
      } else if (err.find("VID:PID") == std::string::npos) {
        std::abort();
      }
      break;
    }
    case 2: {
      const auto keys = parse_key_map(text);
      if (keys.ok()) {
        for (int k : *keys)
          if (k <= 0 || k > KEY_MAX) std::abort();
      } else if (keys.error().rfind("key map: unknown key '", 0) != 0) {
        std::abort();
      }
      break;
    }
  }
  return 0;
}
