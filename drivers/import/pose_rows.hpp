#pragma once
// Recorded positions as text rows -> pose_t, for `ips-import poses` (TRUTH, or an outside
// estimator's output on POSE_*). One row a position: time, x, y[, z], and optionally an
// orientation (quaternion qw,qx,qy,qz or a heading) and a tag column. Per-tag lever arms make one
// rigid body give several tags' positions: tag position = body position + R(body) * lever (body
// frame). The result is then put into the site frame: p_site = Rz(rotate) * p + offset. Dwell
// intervals (start, end, x, y[, z][, tag], the file of `ips-eval --dwell`) become poses at a rate
// through each interval. Pure: text in, messages out.
#include <Eigen/Core>
#include <cstdint>
#include <ips/pose_t.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/import/row_time.hpp"
#include "loggers/eval/dwell_file.hpp"

namespace ips::import {

// t, x, y, z, qw, qx, qy, qz, heading, tag.
const std::vector<table::KnownColumn>& pose_columns();

struct LeverArm {
  std::string tag;
  Eigen::Vector3d body = Eigen::Vector3d::Zero();  // m, body frame (x forward, y left, z up)
};
// "T2=0.3,-0.1,0" -> a lever arm; the reason when it is not one.
std::string parse_lever_arm(std::string_view text, LeverArm& out);

// How the file's frame maps to the site's: p_site = Rz(rotate_rad) * p + offset.
struct FrameTransform {
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  double rotate_rad = 0;
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const;
};

enum class HeadingUnit : uint8_t { kAuto, kDeg, kRad };

struct PoseOptions {
  std::string columns;  // --columns; empty: by header names, else "t,x,y,z"
  table::ReadOptions read;
  TimeOptions time;
  table::UnitScale unit;  // positions to metres (--unit)
  std::string tag;        // for files without a tag column
  std::vector<LeverArm> lever_arms;
  FrameTransform frame;
  // kAuto: degrees when the heading column's header says "deg", else radians.
  HeadingUnit heading_unit = HeadingUnit::kAuto;
  double z = 0;  // height when the file has no z column
  // pose_t fields: source ("truth" on TRUTH), position_cov filled with cov (0 for truth, NaN for
  // an estimate whose uncertainty is unknown).
  std::string source = "truth";
  double cov = 0;
};

struct PoseFile {
  std::vector<pose_t> poses;
  std::vector<std::string> tags;  // in order of first appearance
  table::ImportTally tally;
  std::string columns;
  std::string time_unit;
  bool relative_times = false;
  bool planar = false;  // no z column: z = PoseOptions::z
  std::string error;    // empty when usable
};

PoseFile read_poses(std::string_view text, const std::string& name, const PoseOptions& options);

// Dwell intervals -> poses every 1/rate_hz s from each start to its end (both included; velocity
// 0, heading unknown). Interval tags, else options.tag. The tally is the dwell file's.
PoseFile dwell_poses(const eval::DwellFile& dwell, double rate_hz, const PoseOptions& options);

}  // namespace ips::import
