#include "estimators/pdr/step_length.hpp"

#include <algorithm>
#include <cmath>

namespace ips::pdr {

std::optional<StepModel> parse_step_model(const std::string& n) {
  if (n == "static") return StepModel::kStatic;
  if (n == "weinberg") return StepModel::kWeinberg;
  if (n == "modified_weinberg") return StepModel::kModifiedWeinberg;
  if (n == "kang") return StepModel::kKang;
  if (n == "kim") return StepModel::kKim;
  if (n == "scarlett") return StepModel::kScarlett;
  if (n == "tian") return StepModel::kTian;
  if (n == "levi") return StepModel::kLevi;
  return std::nullopt;
}

const char* step_model_name(StepModel m) {
  switch (m) {
    case StepModel::kStatic: return "static";
    case StepModel::kWeinberg: return "weinberg";
    case StepModel::kModifiedWeinberg: return "modified_weinberg";
    case StepModel::kKang: return "kang";
    case StepModel::kKim: return "kim";
    case StepModel::kScarlett: return "scarlett";
    case StepModel::kTian: return "tian";
    case StepModel::kLevi: return "levi";
  }
  return "?";
}

double step_length_feature(const StepLengthParams& p, const DetectedStep& s) {
  const double da = std::max(s.a_max - s.a_min, 1e-6);
  const double f = s.interval_s > 0 ? 1.0 / s.interval_s : p.f0_hz;
  switch (p.model) {
    case StepModel::kStatic: return p.height_m;
    case StepModel::kWeinberg:
    case StepModel::kModifiedWeinberg: return std::pow(da, 0.25);
    case StepModel::kKang: return std::log10(da);
    case StepModel::kKim: return std::cbrt(std::max(s.abs_avg, 0.0));
    case StepModel::kScarlett: return (s.a_avg - s.a_min) / da;
    case StepModel::kTian: return p.height_m * std::sqrt(f);
    case StepModel::kLevi: return f - p.f0_hz;
  }
  return 0;
}

double step_length(const StepLengthParams& p, const DetectedStep& s) {
  const double x = step_length_feature(p, s);
  double sl = p.k * x;
  if (p.model == StepModel::kModifiedWeinberg || p.model == StepModel::kKang) sl -= p.k2;
  if (p.model == StepModel::kLevi) sl = p.s0_m + p.m_per_hz * x;
  return std::clamp(sl, p.min_m, p.max_m);
}

}  // namespace ips::pdr
