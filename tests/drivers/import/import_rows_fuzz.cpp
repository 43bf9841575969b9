// libFuzzer: ips-import's row readers on arbitrary text: ranges (by header, by --columns, tagged
// lines), positions (with lever arms), and the site made of the rows' anchors; the raw TWR
// timestamp columns (uwb-cucudasluv's by name, or DS-TWR by --columns), with the range taken from
// them or from the file. Never a crash; every message is valid (finite values, valid ids), every
// reason printable.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/device_text.hpp"
#include "core/site.hpp"
#include "drivers/import/pose_rows.hpp"
#include "drivers/import/range_rows.hpp"
#include "drivers/import/site_rows.hpp"

namespace {

void check_printable(const std::string& s) {
  if (!ips::printable_ascii(s)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  // The first byte picks the options, the rest is the file.
  const uint8_t mode = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);

  ips::import::RangeOptions ro;
  if (mode & 1) ro.tag = "T1";
  if (mode & 2) ro.anchor = "A1";
  if (mode & 4) {
    ro.read.row_tag = "range2";
    ro.columns = "-,t,range,-,ax,ay,anchor";
  }
  if (mode & 8) ro.time.rate_hz = 10;
  if (mode & 128) {
    ro.range_from = ips::import::RangeFrom::kTimestamps;
    ro.counter_bits = (mode & 64) ? 40 : 32;
    if (mode & 4) {
      ro.read.row_tag.clear();
      ro.columns = "t,tag,anchor,poll_tx,poll_rx,resp_tx,resp_rx,final_tx,final_rx";
    }
  }
  const auto rf = ips::import::read_ranges(text, "fuzz", ro);
  check_printable(rf.error);
  check_printable(rf.tally.first_bad_reason);
  check_printable(rf.twr.first_bad_reason);
  for (const auto& m : rf.ranges) {
    if (!std::isfinite(m.range_m) || m.range_m < 0 || m.range_m > ips::import::kMaxRangeM) std::abort();
    if (!ips::valid_device_id(m.tag_id) || !ips::valid_device_id(m.anchor_id)) std::abort();
  }
  for (const auto& x : rf.exchanges) {
    if (x.n_stamps != 4 && x.n_stamps != 6) std::abort();
    if (!std::isnan(x.range_m) &&
        !(x.range_m >= ips::import::kMinStampRangeM && x.range_m <= ips::import::kMaxRangeM))
      std::abort();
    if (std::isinf(x.clock_offset_ppm) || !(x.tick_s > 0)) std::abort();
    if (!ips::valid_device_id(x.tag_id) || !ips::valid_device_id(x.anchor_id)) std::abort();
  }
  if (!rf.anchors.empty()) {
    const std::string yaml = ips::import::site_yaml_from_anchors("fuzz", rf.anchors, rf.tags, {});
    try {
      (void)ips::parse_site_text(yaml, "fuzz");
    } catch (const ips::SiteError&) {
      std::abort();  // the rows' anchors always make a site
    }
  }

  ips::import::PoseOptions po;
  po.tag = "T1";
  if (mode & 16) {
    ips::import::LeverArm arm;
    arm.tag = "T2";
    arm.body = Eigen::Vector3d(0.1, 0.2, 0.3);
    po.lever_arms.push_back(arm);
  }
  if (mode & 32) {
    po.read.row_tag = "point2";
    po.columns = "-,t,x,y";
  }
  if (mode & 64) po.frame.rotate_rad = 1.0;
  const auto pf = ips::import::read_poses(text, "fuzz", po);
  check_printable(pf.error);
  for (const auto& m : pf.poses)
    for (double p : m.position)
      if (!std::isfinite(p)) std::abort();
  return 0;
}
