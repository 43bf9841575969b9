#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {
// FNV-1a: a hash that is the same on every platform and build.
uint64_t stream_key(const std::string& name) {
  uint64_t h = 14695981039346656037ULL;
  for (unsigned char c : name) h = (h ^ c) * 1099511628211ULL;
  return h;
}
}  // namespace

std::mt19937_64 stream_rng(uint64_t seed, const std::string& name) {
  const uint64_t key = stream_key(name);
  std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                    static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32)};
  return std::mt19937_64(seq);
}

int64_t period_us(double rate_hz) { return std::max<utime_t>(1, s_to_utime(1.0 / rate_hz)); }

double param_in_range(const YamlField& section, const char* key, double fallback, double lo,
                      double hi) {
  return section.get_double_in(key, fallback, lo, hi);
}

}  // namespace ips::sim
