#pragma once
// Step-length models of source 002 section 2.3 (Table of models), from the extremes of the
// filtered vertical linear acceleration within the step and the step frequency:
//   static             SL = K h                      (h: body height; K 0.415 men, 0.413 women)
//   weinberg           SL = K (a_max - a_min)^(1/4)
//   modified_weinberg  SL = K1 (a_max - a_min)^(1/4) - K2     (default: K1 = 1, K2 = 0.828,
//                      002's calibration (3.11) read as this model; the printed K1 = 0.828 form
//                      would need a_max - a_min below its own detection threshold)
//   kang               SL = K1 log10(a_max - a_min) - K2
//   kim                SL = K cbrt(mean |a|)
//   scarlett           SL = K (a_avg - a_min) / (a_max - a_min)
//   tian               SL = K h sqrt(f)
//   levi               SL = S0 + m (f - f0)
// The result is clamped to [min_m, max_m] (a walking step; 002's stairs show Weinberg reading
// 0.8 m for 0.28 m steps, which no clamp can fix).
#include <optional>
#include <string>

#include "estimators/pdr/step_detector.hpp"

namespace ips::pdr {

enum class StepModel { kStatic, kWeinberg, kModifiedWeinberg, kKang, kKim, kScarlett, kTian, kLevi };
std::optional<StepModel> parse_step_model(const std::string& name);
const char* step_model_name(StepModel m);

struct StepLengthParams {
  StepModel model = StepModel::kModifiedWeinberg;
  double k = 1.0;        // K or K1
  double k2 = 0.828;     // K2 (modified Weinberg, Kang)
  double height_m = 1.75;  // body height (static, tian)
  double s0_m = 0.7, f0_hz = 1.8, m_per_hz = 0.3;  // levi
  double min_m = 0.2, max_m = 1.5;
};

// The model's length before the constant K (K1) is applied and before clamping: what a
// calibration over a known distance scales. (Modified Weinberg and Kang subtract K2 after.)
double step_length_feature(const StepLengthParams& p, const DetectedStep& s);
double step_length(const StepLengthParams& p, const DetectedStep& s);

}  // namespace ips::pdr
