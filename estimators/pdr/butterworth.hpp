#pragma once
// Digital Butterworth low-pass filter as a cascade of second-order sections: the step detector's
// pre-filter of source 002 (9th order, fc = 3 Hz; ../shared/reference/002_pdr.md section 2.1).
// Design: analog prototype poles on the circle of the pre-warped cut-off, mapped by the bilinear
// transform, zeros at z = -1, each section scaled to unit gain at DC. Causal (the source does not
// say; a step detector running live must be): a 9th-order 3 Hz filter delays a 1.8 Hz step
// signal by about 0.2 s, which only shifts step times.
#include <vector>

namespace ips::pdr {

class ButterworthLowPass {
 public:
  // order 1..12, 0 < cutoff_hz < sample_rate_hz / 2.
  ButterworthLowPass(int order, double cutoff_hz, double sample_rate_hz);
  double step(double x);
  // Starts in steady state for a constant input x (no start-up transient).
  void reset(double x = 0.0);
  int order() const { return order_; }

 private:
  struct Section {  // y = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2) x, transposed DF II
    double b0, b1, b2, a1, a2;
    double s1 = 0, s2 = 0;
  };
  int order_;
  std::vector<Section> sections_;
};

}  // namespace ips::pdr
