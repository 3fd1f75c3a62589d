// Fuzz target: the skill model JSON; a model that loads must classify a
// sequence of its own width without crashing.
#include <cstdint>
#include <string>

#include "dentar/training/assess.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::training;
  if (size > (1u << 16)) return 0;
  auto m = model_from_json(std::string(reinterpret_cast<const char*>(data), size), "model.json");
  if (!m) return 0;
  const Eigen::Index d = m->scaler.mean.size();
  if (d > 64 || m->options.dtw_length > 1000 || m->options.dtw_length < 2) return 0;
  Sequence x = Sequence::Zero(8, d);
  for (Eigen::Index i = 0; i < 8; ++i) x(i, 0) = static_cast<double>(i);
  (void)classify(*m, x);
  return 0;
}
