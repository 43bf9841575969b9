// libFuzzer target: arbitrary bytes as a UDP datagram and as the lines of a recorded file through
// what ips-phone-imu does with them (row parser in the tagged and HyperIMU mappings, the
// assembler and time mapping of PhoneStreams; --file's FileImport on core/table_text.hpp with a
// header, --columns with a time unit, and --rate). Checks that nothing crashes or throws, that
// every error has a printable reason, that every accepted reading is finite with a time >= 0, and
// that every published message has a plausible utime and NaN only for whole sensors.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/line_buffer.hpp"
#include "core/time.hpp"
#include "drivers/phone_imu/csv_row.hpp"
#include "drivers/phone_imu/file_import.hpp"
#include "drivers/phone_imu/phone_streams.hpp"

namespace {
using namespace ips::phone_imu;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}
bool printable(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}
void check_axes(const double* v) {
  const int nan = std::isnan(v[0]) + std::isnan(v[1]) + std::isnan(v[2]);
  check(nan == 0 || nan == 3, "a sensor partly NaN");
  for (int i = 0; i < 3; ++i) check(std::isnan(v[i]) || std::isfinite(v[i]), "inf");
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  RowFormat formats[2];
  parse_column_mapping("tagged", formats[0]);
  parse_column_mapping("t,ax,ay,az,gx,gy,gz,mx,my,mz", formats[1]);
  formats[1].time_unit = TimeUnit::kMs;
  auto check_msg = [](const ips::imu_t& m) {
    check(ips::plausible_utime(m.utime), "utime");
    check_axes(m.accel);
    check_axes(m.gyro);
    check_axes(m.mag_ut);
  };
  FileImportOptions by_header, by_columns, by_rate;
  by_columns.columns = "t,-,ax,ay,az";
  by_columns.time_unit = ips::table::TimeUnit::kNs;
  by_rate.columns = "ax,ay,az,gx,gy,gz";
  by_rate.rate_hz = 820;
  by_rate.read.separator = ',';
  FileImport files[3] = {FileImport(by_header, check_msg), FileImport(by_columns, check_msg),
                         FileImport(by_rate, check_msg)};
  PhoneStreams streams({}, [](const ips::imu_t& m) {
    check(ips::plausible_utime(m.utime), "utime");
    check(m.device_utime >= 0, "device_utime");
    check_axes(m.accel);
    check_axes(m.gyro);
    check_axes(m.mag_ut);
    check(!std::isnan(m.accel[0]), "accel-driven message without accel");
  });
  int64_t host = 1'700'000'000'000'000;
  std::vector<SensorSample> batch;
  ips::LineBuffer lines(512);
  lines.feed(bytes, [&](std::string_view line) {
    for (const RowFormat& f : formats) {
      const RowParse r = parse_row(line, f);
      if (!r.ok) {
        check(printable(r.reason), "reason");
        continue;
      }
      check(r.count >= 0 && r.count <= 3 && r.device_us >= 0, "row");
      batch.assign(r.samples.begin(), r.samples.begin() + r.count);
      for (const SensorSample& s : batch)
        for (double v : s.xyz) check(std::isfinite(v), "reading not finite");
      streams.on_batch(line.size() % 2 ? "a" : "b", host, batch);
      host += 10'000;
    }
    for (FileImport& f : files) f.feed(line);
  });
  for (FileImport& f : files) {
    check(f.setup_error().empty(), "setup");
    const std::string verdict = f.finish();
    check(verdict.empty() || printable(verdict), "verdict");
    check(f.tally().messages == 0 || printable(f.describe()), "describe");
    const auto& t = f.tally();
    check(t.bad == 0 || printable(t.first_bad_reason), "reason");
    // Nothing silent: no messages from lines that are not all blank or comments is a verdict.
    check(t.messages > 0 || t.lines == t.skipped || !verdict.empty(), "silent");
  }
  return 0;
}
