#include "estimators/pdr/butterworth.hpp"

#include <cmath>
#include <complex>
#include <stdexcept>

namespace ips::pdr {

ButterworthLowPass::ButterworthLowPass(int order, double cutoff_hz, double sample_rate_hz)
    : order_(order) {
  if (order < 1 || order > 12 || !(cutoff_hz > 0) || !(sample_rate_hz > 2 * cutoff_hz))
    throw std::invalid_argument("Butterworth: order 1..12 and 0 < cutoff < rate / 2");
  const double fs2 = 2.0 * sample_rate_hz;
  const double wc = fs2 * std::tan(M_PI * cutoff_hz / sample_rate_hz);  // pre-warped, rad/s
  for (int k = 0; k < order / 2; ++k) {
    // The upper-half-plane pole of the k-th conjugate pair, then its bilinear image.
    const std::complex<double> s =
        wc * std::exp(std::complex<double>(0, M_PI * (2.0 * k + order + 1) / (2.0 * order)));
    const std::complex<double> z = (fs2 + s) / (fs2 - s);
    Section sec{};
    sec.a1 = -2.0 * z.real();
    sec.a2 = std::norm(z);
    const double gain = (1.0 + sec.a1 + sec.a2) / 4.0;  // unit gain at z = 1
    sec.b0 = gain;
    sec.b1 = 2.0 * gain;
    sec.b2 = gain;
    sections_.push_back(sec);
  }
  if (order % 2 == 1) {  // the real pole at -wc
    const double z = (fs2 - wc) / (fs2 + wc);
    Section sec{};
    sec.a1 = -z;
    sec.a2 = 0.0;
    sec.b0 = (1.0 - z) / 2.0;
    sec.b1 = sec.b0;
    sec.b2 = 0.0;
    sections_.push_back(sec);
  }
}

double ButterworthLowPass::step(double x) {
  for (Section& s : sections_) {
    const double y = s.b0 * x + s.s1;
    s.s1 = s.b1 * x - s.a1 * y + s.s2;
    s.s2 = s.b2 * x - s.a2 * y;
    x = y;
  }
  return x;
}

void ButterworthLowPass::reset(double x) {
  // Unit DC gain: every section's input and output are x in steady state.
  for (Section& s : sections_) {
    s.s2 = s.b2 * x - s.a2 * x;
    s.s1 = s.b1 * x - s.a1 * x + s.s2;
  }
}

}  // namespace ips::pdr
