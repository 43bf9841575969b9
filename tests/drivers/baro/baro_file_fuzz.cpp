// libFuzzer target: arbitrary bytes as a recorded barometer log through ips-baro --file's reader
// (read_baro_file) in the line format and in column layouts (the loruro one, a time column, two
// sensors), with the separator, header mode and rate chosen by the first byte. Checks that nothing
// crashes or throws, that every sample passes reading_problem() and belongs to a known sensor,
// that the counts add up (every data row used or rejected; samples = used per-sensor counts),
// and that the verdict and the notes are printable.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "drivers/baro/baro_file.hpp"

namespace {

using namespace ips::baro;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

bool printable(const std::string& s) {
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t mode = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  static const char* const kColumns[] = {"", "mpl,p,t", "time,p,t,h", "p,-,B2,B2.t"};
  static const char* const kUnits[] = {"", "0.001hPa,0.001hPa,0.001degC", "-,hPa,K,%", ""};
  FileOptions o;
  o.name = "fuzz.log";
  std::string reason;
  const int layout = mode & 3;
  check(parse_file_layout(kColumns[layout], kUnits[layout], "T1", o.layout, reason), "layout");
  if (mode & 4) o.read.separator = (mode & 8) ? ';' : ',';
  if (mode & 16) o.read.header = ips::table::HeaderMode::kNone;
  if (mode & 32) o.rate_hz = 10;
  if (mode & 64) o.start_utime = 1'700'000'000'000'000;
  if (mode & 128) o.end_utime = 1'700'000'100'000'000;
  const FileResult r = read_baro_file(text, o);
  check(printable(r.error) && printable(r.time_note), "unprintable note");
  int64_t used = 0;
  for (const SensorTally& s : r.sensors) used += s.samples;
  if (r.error.empty()) {
    check(used == static_cast<int64_t>(r.samples.size()), "sample count");
    check(r.tally.messages == used, "message count");
  }
  check(r.tally.rows + r.tally.bad >= r.data_rows, "row count");
  for (const FileSample& s : r.samples) {
    check(s.sensor >= 0 && static_cast<size_t>(s.sensor) < o.layout.sensors.size(), "sensor");
    check(reading_problem(s.reading).empty(), "a sample with a problem");
  }
  ips::table::ImportExpectation e;
  e.input = o.name;
  e.columns = o.layout.describe();
  e.separator = o.read.separator;
  check(printable(ips::table::import_verdict(r.tally, e)), "unprintable verdict");
  return 0;
}
