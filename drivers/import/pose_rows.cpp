#include "drivers/import/pose_rows.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "drivers/import/row_loop.hpp"

namespace ips::import {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool contains_deg(std::string_view header) {
  std::string h = table::normalise_header_name(header);
  // normalise_header_name cuts at a bracket: look at the raw text too ("heading(deg)").
  for (char c : header) h.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  return h.find("deg") != std::string::npos;
}

pose_t base_pose(const PoseOptions& o) {
  pose_t m;
  m.source = o.source;
  for (double& c : m.position_cov) c = o.cov;
  for (double& v : m.velocity) v = kNaN;
  m.heading_rad = kNaN;
  m.num_used = 0;
  m.residual_m = kNaN;
  m.status = pose_t::STATUS_OK;
  return m;
}

void note_tag(std::vector<std::string>& tags, const std::string& tag) {
  if (std::find(tags.begin(), tags.end(), tag) == tags.end()) tags.push_back(tag);
}

double wrap_pi(double a) { return std::remainder(a, 2 * M_PI); }

}  // namespace

const std::vector<table::KnownColumn>& pose_columns() {
  static const std::vector<table::KnownColumn> known = {
      {"t", "time|timestamp|t|utime|stamp|timeus|timems|times|timens"},
      {"x", "x|posx|positionx|px|xm|posex|ex"},
      {"y", "y|posy|positiony|py|ym|posey|ey"},
      {"z", "z|posz|positionz|pz|zm|posez|height"},
      {"qw", "qw|quatw|orientationw|rotw|w"},
      {"qx", "qx|quatx|orientationx|rotx"},
      {"qy", "qy|quaty|orientationy|roty"},
      {"qz", "qz|quatz|orientationz|rotz"},
      {"heading", "heading|headingdegrees|headingdeg|headingrad|yaw|yawdeg|yawrad|theta|psi"},
      {"tag", "tag|tagid|id|name"},
  };
  return known;
}

std::string parse_lever_arm(std::string_view text, LeverArm& out) {
  const size_t eq = text.find('=');
  if (eq == std::string_view::npos) return "expected TAG=x,y,z, got '" + table::excerpt(text) + "'";
  out.tag = std::string(text.substr(0, eq));
  if (!valid_device_id(out.tag)) return "tag '" + table::excerpt(out.tag) + "' is not 1 to 32 of A-Za-z0-9_.:-";
  std::vector<std::string_view> parts;
  if (!table::split_fields(text.substr(eq + 1), ',', parts) || parts.size() != 3)
    return "expected TAG=x,y,z (three numbers, m), got '" + table::excerpt(text) + "'";
  for (int k = 0; k < 3; ++k)
    if (!table::parse_number(parts[static_cast<size_t>(k)], out.body[k]) ||
        std::fabs(out.body[k]) > 1000)
      return "'" + table::excerpt(parts[static_cast<size_t>(k)]) + "' is not a length in m";
  return "";
}

Eigen::Vector3d FrameTransform::apply(const Eigen::Vector3d& p) const {
  const double c = std::cos(rotate_rad), s = std::sin(rotate_rad);
  return Eigen::Vector3d(c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z()) + offset;
}

PoseFile read_poses(std::string_view text, const std::string& name, const PoseOptions& options) {
  PoseFile out;
  bool quaternion = false, heading = false, heading_deg = false;
  const RowLoopSpec spec{name,           options.read, options.time, options.columns,
                         pose_columns(), "x",          "t,x,y,z",    "no position"};
  auto default_list = [&](const table::TableReader& reader) {
    // The default layout; z only when the first row has the field for it.
    const bool rate = options.time.rate_hz > 0;
    const bool z = reader.fields().size() >= (rate ? 3u : 4u);
    return rate ? (z ? "x,y,z" : "x,y") : (z ? "t,x,y,z" : "t,x,y");
  };
  auto check = [&](const table::TableReader& reader, const table::Columns& columns) -> std::string {
    std::string missing;
    if (!columns.has("x")) missing = "x";
    else if (!columns.has("y")) missing = "y";
    else if (!columns.has("t") && options.time.rate_hz <= 0) missing = "t";
    if (!missing.empty())
      return "no " + missing + " column (columns " + columns.describe() +
             "); name them with --columns t,x,y[,z][,qw,qx,qy,qz|heading][,tag]" +
             (missing == "t" ? " or give --rate HZ" : "");
    quaternion = columns.has("qw") && columns.has("qx") && columns.has("qy") && columns.has("qz");
    heading = columns.has("heading");
    if (!options.lever_arms.empty() && !quaternion && !heading)
      return "--lever-arm needs the body's orientation: a quaternion (qw,qx,qy,qz) "
             "or a heading column (columns " +
             columns.describe() + ")";
    if (options.lever_arms.empty() && !columns.has("tag") && options.tag.empty())
      return "no tag column: give --tag T (or --lever-arm TAG=x,y,z)";
    heading_deg = options.heading_unit == HeadingUnit::kDeg;
    if (options.heading_unit == HeadingUnit::kAuto && heading) {
      const int i = columns.index("heading");
      heading_deg = static_cast<size_t>(i) < reader.header().size() &&
                    contains_deg(reader.header()[static_cast<size_t>(i)]);
    }
    out.planar = !columns.has("z");
    return "";
  };
  read_rows(text, spec, out, default_list, check, [&](const Row& row) {
    Eigen::Vector3d p(0, 0, options.z);
    if (!table::parse_number(row.field("x"), p.x()) ||
        !table::parse_number(row.field("y"), p.y())) {
      row.reject("x or y is not a number");
      return false;
    }
    p.x() = options.unit.to_si(p.x());
    p.y() = options.unit.to_si(p.y());
    if (row.has("z")) {
      if (!table::parse_number(row.field("z"), p.z())) {
        row.reject("z is not a number");
        return false;
      }
      p.z() = options.unit.to_si(p.z());
    }
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e7) {
      row.reject("position out of range");
      return false;
    }
    // The body's rotation (file frame), when known.
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    bool oriented = false;
    if (quaternion) {
      double q[4];
      const char* names[4] = {"qw", "qx", "qy", "qz"};
      for (int k = 0; k < 4; ++k)
        if (!table::parse_number(row.field(names[k]), q[k])) {
          row.reject("quaternion component is not a number");
          return false;
        }
      Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
      const double n = quat.norm();
      if (!(n > 0.5 && n < 1.5)) {
        row.reject("quaternion is not a rotation (norm far from 1)");
        return false;
      }
      r = quat.normalized().toRotationMatrix();
      oriented = true;
    } else if (heading && !missing_field(row.field("heading"))) {
      double h = 0;
      if (!table::parse_number(row.field("heading"), h) || std::fabs(h) > 1e6) {
        row.reject("heading is not a number");
        return false;
      }
      if (heading_deg) h *= M_PI / 180.0;
      r = Eigen::AngleAxisd(h, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      oriented = true;
    }
    if (!options.lever_arms.empty() && !oriented) {
      row.reject("no orientation for the lever arms");
      return false;
    }
    const auto t = row.time();
    if (!t) return false;
    const double yaw = std::atan2(r(1, 0), r(0, 0));
    auto emit = [&](const std::string& tag, const Eigen::Vector3d& body_point) {
      pose_t m = base_pose(options);
      m.utime = *t;
      m.tag_id = tag;
      const Eigen::Vector3d site = options.frame.apply(body_point);
      for (int k = 0; k < 3; ++k) m.position[k] = site[k];
      if (oriented) m.heading_rad = wrap_pi(yaw + options.frame.rotate_rad);
      if (out.planar) m.status |= pose_t::STATUS_2D;
      note_tag(out.tags, tag);
      out.poses.push_back(std::move(m));
      ++out.tally.messages;
    };
    if (!options.lever_arms.empty()) {
      for (const LeverArm& arm : options.lever_arms) emit(arm.tag, p + r * arm.body);
    } else {
      const std::string tag = row.has("tag") ? std::string(row.field("tag")) : options.tag;
      if (!valid_device_id(tag)) {
        row.reject("tag " + quoted_field(tag) + " is not 1 to 32 of A-Za-z0-9_.:-");
        return false;
      }
      emit(tag, p);
    }
    return true;
  });
  return out;
}

PoseFile dwell_poses(const eval::DwellFile& dwell, double rate_hz, const PoseOptions& options) {
  PoseFile out;
  out.tally = dwell.tally;
  out.tally.messages = 0;
  out.columns = dwell.columns;
  out.time_unit = dwell.time_unit;
  out.error = dwell.error;
  if (!out.error.empty()) return out;
  const double period_us = 1e6 / rate_hz;
  for (const eval::DwellInterval& d : dwell.intervals) {
    const std::string tag = d.tag.empty() ? options.tag : d.tag;
    if (!valid_device_id(tag)) {
      out.error = "a dwell interval has no tag: give --tag T";
      return out;
    }
    const bool planar = !std::isfinite(d.z);
    const Eigen::Vector3d site =
        options.frame.apply(Eigen::Vector3d(d.x, d.y, planar ? options.z : d.z));
    note_tag(out.tags, tag);
    out.planar = out.planar || planar;
    for (int64_t k = 0;; ++k) {
      const double t = static_cast<double>(d.start) + static_cast<double>(k) * period_us;
      if (t > static_cast<double>(d.end) + 0.5) break;
      pose_t m = base_pose(options);
      m.utime = static_cast<int64_t>(std::llround(t));
      m.tag_id = tag;
      for (int j = 0; j < 3; ++j) {
        m.position[j] = site[j];
        m.velocity[j] = 0;
      }
      if (planar) m.status |= pose_t::STATUS_2D;
      out.poses.push_back(std::move(m));
      ++out.tally.messages;
      if (out.poses.size() > 50'000'000) {
        out.error = "dwell intervals too long for --dwell-rate (over 50 million poses)";
        return out;
      }
    }
  }
  if (out.poses.empty()) out.error = "no dwell interval";
  return out;
}

}  // namespace ips::import
