#pragma once
// A recorded IMU file -> imu_t, through core/table_text.hpp: a phone app's CSV (HyperIMU, the
// Oxford step counter's accelerometer.csv, Sensor Logger's columns), the semicolon rows of 002's
// logger, or a foot-mounted IMU's dump with no time column (OpenShoe, 820 Hz).
//
//   - separator: given (--separator) or detected from the first data line;
//   - columns: --columns ("t,-,ax,ay,az": '-' skips, a sensor's three axes or none), else the
//     header's names (KnownColumn aliases below), else t,ax,ay,az,gx,gy,gz,mx,my,mz;
//   - time: the t column in --time-unit (default: guessed from the first time's magnitude as an
//     epoch time, else s), ISO-8601 too; placed by --file-start; or no t column and --rate HZ
//     (row k at start + k/HZ; without --file-start the first row is at 1 s after the Unix epoch,
//     the first time every program takes as plausible);
//   - units: --accel-unit, --gyro-unit, --mag-unit (UnitScales).
// Every data row is one batch of PhoneStreams (the accelerometer-driven assembler, a fixed
// offset), so a file makes the same messages as the live paths. A sensor whose three fields are
// empty in a row is absent from it; a sensor left out of the columns is NaN in every message.
// Rejected rows are counted in an ImportTally, and finish() gives the nothing-silent verdict.
// Pure: lines in, messages out; no I/O, never throws.
#include <array>
#include <cstdint>
#include <functional>
#include <ips/imu_t.hpp>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/phone_imu/phone_streams.hpp"
#include "drivers/phone_imu/sensor_sample.hpp"

namespace ips::phone_imu {

// The columns a file may have: t, ax..az, gx..gz, mx..mz, with the header names that mean them.
const std::vector<table::KnownColumn>& file_known_columns();
inline constexpr std::string_view kDefaultFileColumns = "t,ax,ay,az,gx,gy,gz,mx,my,mz";

struct FileImportOptions {
  std::string input = "file";                // its name, for messages
  std::optional<std::string> columns;        // --columns; nullopt: header names, else the default
  table::ReadOptions read;                   // --separator, --header
  std::optional<table::TimeUnit> time_unit;  // nullopt: guessed
  std::optional<int64_t> start_utime;        // --file-start
  double rate_hz = 0;                        // --rate: no time column
  UnitScales units;
  AssemblerConfig assembler;
  std::string device_id = "phone";
  std::string source = "ips-phone-imu:file";
};

// The column mapping resolved to indices; the reason when it is not usable.
struct FileLayout {
  int time_column = -1;
  std::array<std::array<int, 3>, 3> axis_column{{{-1, -1, -1}, {-1, -1, -1}, {-1, -1, -1}}};
  int columns_needed = 0;
};
// need_accel: the accelerometer-driven assembly makes one message per accelerometer reading.
std::string file_layout_from(const table::Columns& columns, bool rate, bool need_accel,
                             FileLayout& layout);

class FileImport {
 public:
  FileImport(FileImportOptions options, std::function<void(const imu_t&)> publish);

  // A --columns that cannot be used (checked before any line): empty when fine.
  const std::string& setup_error() const { return setup_error_; }

  // One line of the file, without its line end (empty lines too, so line numbers are right).
  void feed(std::string_view line);
  // After the last line: the verdict of table::import_verdict (empty: acceptable), or the reason
  // the mapping could not be made (a header with no sensor column).
  std::string finish();

  const table::ImportTally& tally() const { return tally_; }
  int64_t dropped() const { return dropped_; }  // readings not newer than the last, or implausible
  int64_t first_utime() const { return first_utime_; }
  int64_t last_utime() const { return last_utime_; }
  // What was used, one phrase each ("comma-separated", "columns t,-,ax,ay,az from --columns",
  // "times in ns (--time-unit)"), known after the first data line; and warnings (times since
  // boot kept as they are).
  std::string describe() const;
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  bool set_up_layout();
  void row(const std::vector<std::string_view>& fields, std::string_view line);

  FileImportOptions o_;
  std::function<void(const imu_t&)> publish_;
  table::TableReader reader_;
  table::ImportTally tally_;
  table::Columns columns_;
  FileLayout layout_;
  table::RowClock clock_;
  table::TimeUnit unit_ = table::TimeUnit::kS;
  std::string setup_error_, fatal_, columns_from_, unit_from_;
  std::vector<std::string> warnings_;
  std::unique_ptr<PhoneStreams> streams_;
  std::vector<SensorSample> batch_;
  bool laid_out_ = false;
  int64_t dropped_ = 0, first_utime_ = 0, last_utime_ = 0;
};

}  // namespace ips::phone_imu
