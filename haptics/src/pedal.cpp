#include "dentar/haptics/pedal.h"

namespace dentar::haptics {

std::string ManualPedal::status() const {
  if (!connected()) return name_ + ": not connected";
  return name_ + (pressed() ? ": pressed" : ": released");
}

}  // namespace dentar::haptics
