// The IIO barometer reader (drivers/baro/iio_device.hpp) and the sensor that keeps one
// (drivers/baro/iio_sensor.hpp), on a fake sysfs tree in a temporary directory: attributes as
// the kernel prints them (IIO ABI units: kPa, milli degC, milli percent), _input against
// _raw * _scale with _offset, humidity present or not, finding devices by name (unknown and
// duplicate names), a device that vanishes and returns, and oversampling.
#include "drivers/baro/iio_device.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "drivers/baro/iio_sensor.hpp"

namespace ips::baro {
namespace {

namespace fs = std::filesystem;

struct FakeSysfs {
  fs::path root;
  FakeSysfs() {
    char tmpl[] = "/tmp/ips-baro-test-XXXXXX";
    root = mkdtemp(tmpl);
  }
  ~FakeSysfs() { fs::remove_all(root); }
  // Makes root/<entry> with a `name` and the given attributes (name -> text).
  std::string device(const std::string& entry, const std::string& name,
                     const std::map<std::string, std::string>& attributes) const {
    const fs::path dir = root / entry;
    fs::create_directories(dir);
    write(dir / "name", name + "\n");
    for (const auto& [attribute, text] : attributes) write(dir / attribute, text);
    return dir.string();
  }
  static void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }
  static std::string read(const fs::path& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
};

const std::map<std::string, std::string> kBmp280 = {{"in_pressure_input", "101.325120000\n"},
                                                    {"in_temp_input", "21430\n"}};
// The same sample from raw values: 25331280 * 0.000004 kPa, (-357 + 2500) * 10 milli degC, and
// a BME280's humidity in milli percent.
const std::map<std::string, std::string> kRawBme280 = {
    {"in_pressure_raw", "25331280\n"}, {"in_pressure_scale", "0.000004000\n"},
    {"in_temp_raw", "-357\n"},         {"in_temp_offset", "2500\n"},
    {"in_temp_scale", "10\n"},         {"in_humidityrelative_input", "45200\n"}};

TEST(BaroIioDevice, ReadsInputAttributesInPascalAndDegrees) {
  FakeSysfs sys;
  IioDevice d;
  std::string error;
  ASSERT_EQ(d.open(sys.device("iio:device0", "bmp280", kBmp280), error),
            IioDevice::OpenStatus::kOpen)
      << error;
  EXPECT_EQ(d.name(), "bmp280");
  EXPECT_FALSE(d.pressure_from_raw());
  EXPECT_TRUE(d.has_temperature());
  EXPECT_FALSE(d.has_humidity());
  BaroReading r;
  std::string reason;
  ASSERT_EQ(d.read(r, reason), IioDevice::ReadStatus::kOk) << reason;
  EXPECT_EQ(r.pressure_pa, 101.32512 * 1000.0);  // kPa -> Pa
  EXPECT_NEAR(r.pressure_pa, 101325.12, 1e-9);
  EXPECT_EQ(r.temperature_c, 21.43);  // milli degC -> degC
  EXPECT_TRUE(std::isnan(r.humidity_pct));
}

TEST(BaroIioDevice, CombinesRawOffsetAndScaleAndReadsHumidity) {
  FakeSysfs sys;
  IioDevice d;
  std::string error, reason;
  ASSERT_EQ(d.open(sys.device("iio:device1", "bme280", kRawBme280), error),
            IioDevice::OpenStatus::kOpen)
      << error;
  EXPECT_TRUE(d.pressure_from_raw());
  EXPECT_TRUE(d.has_humidity());
  BaroReading r;
  ASSERT_EQ(d.read(r, reason), IioDevice::ReadStatus::kOk) << reason;
  EXPECT_EQ(r.pressure_pa, 25331280.0 * 0.000004 * 1000.0);
  EXPECT_NEAR(r.pressure_pa, 101325.12, 1e-6);
  EXPECT_EQ(r.temperature_c, 21.43);
  EXPECT_EQ(r.humidity_pct, 45.2);
}

TEST(BaroIioDevice, HumidityFromRawAndNoTemperatureChannel) {
  FakeSysfs sys;
  IioDevice d;
  std::string error, reason;
  ASSERT_EQ(d.open(sys.device("iio:device0", "odd",
                              {{"in_pressure_input", "99.5\n"},
                               {"in_humidityrelative_raw", "1000\n"},
                               {"in_humidityrelative_scale", "50.5\n"}}),
                   error),
            IioDevice::OpenStatus::kOpen);
  EXPECT_FALSE(d.has_temperature());
  BaroReading r;
  ASSERT_EQ(d.read(r, reason), IioDevice::ReadStatus::kOk) << reason;
  EXPECT_EQ(r.pressure_pa, 99500.0);
  EXPECT_TRUE(std::isnan(r.temperature_c));
  EXPECT_EQ(r.humidity_pct, 50.5);
}

TEST(BaroIioDevice, ATemperatureRawWithoutScaleIsNoChannel) {
  FakeSysfs sys;
  IioDevice d;
  std::string error;
  ASSERT_EQ(d.open(sys.device("iio:device0", "x",
                              {{"in_pressure_input", "99.5\n"}, {"in_temp_raw", "5\n"}}),
                   error),
            IioDevice::OpenStatus::kOpen);
  EXPECT_FALSE(d.has_temperature());
}

TEST(BaroIioDevice, RefusesWhatIsNotABarometerOrNotThere) {
  FakeSysfs sys;
  IioDevice d;
  std::string error;
  const std::string accel = sys.device("iio:device0", "lsm6dsl", {{"in_accel_x_raw", "12\n"}});
  EXPECT_EQ(d.open(accel, error), IioDevice::OpenStatus::kNotBarometer);
  EXPECT_EQ(error, accel +
                       " ('lsm6dsl') has no in_pressure_input, nor in_pressure_raw with "
                       "in_pressure_scale: not a barometer");
  EXPECT_FALSE(d.is_open());
  EXPECT_EQ(d.open(sys.root.string() + "/iio:device7", error), IioDevice::OpenStatus::kMissing);
  EXPECT_EQ(error, sys.root.string() + "/iio:device7: No such file or directory");
  EXPECT_EQ(d.open(accel + "/name", error), IioDevice::OpenStatus::kMissing);
  EXPECT_EQ(error, accel + "/name: not a directory");
}

TEST(BaroIioDevice, ABadValueIsBadAndTheDeviceStays) {
  FakeSysfs sys;
  IioDevice d;
  std::string error, reason;
  const std::string dir = sys.device("iio:device0", "bmp280", kBmp280);
  ASSERT_EQ(d.open(dir, error), IioDevice::OpenStatus::kOpen);
  FakeSysfs::write(dir + "/in_temp_input", "garbage\n");
  BaroReading r;
  EXPECT_EQ(d.read(r, reason), IioDevice::ReadStatus::kBad);
  EXPECT_EQ(reason, "in_temp_input: 'garbage' is not a number");
  FakeSysfs::write(dir + "/in_pressure_input", "");
  EXPECT_EQ(d.read(r, reason), IioDevice::ReadStatus::kBad);
  EXPECT_EQ(reason, "in_pressure_input: empty");
  FakeSysfs::write(dir + "/in_pressure_input", std::string(300, '1'));
  EXPECT_EQ(d.read(r, reason), IioDevice::ReadStatus::kBad);
  EXPECT_EQ(reason, "in_pressure_input: longer than 256 bytes");
  EXPECT_TRUE(d.is_open());
}

TEST(BaroIioDevice, AVanishedDeviceIsGone) {
  FakeSysfs sys;
  IioDevice d;
  std::string error, reason;
  const std::string dir = sys.device("iio:device0", "bmp280", kBmp280);
  ASSERT_EQ(d.open(dir, error), IioDevice::OpenStatus::kOpen);
  fs::remove_all(dir);
  BaroReading r;
  r.pressure_pa = 1.0;
  EXPECT_EQ(d.read(r, reason), IioDevice::ReadStatus::kGone);
  EXPECT_EQ(reason, "in_pressure_input: No such file or directory");
  EXPECT_EQ(r.pressure_pa, 1.0);  // untouched
}

TEST(BaroIioDevices, ListedInNumberOrderWithTheirNames) {
  FakeSysfs sys;
  sys.device("iio:device10", "bmp388", kBmp280);
  sys.device("iio:device2", "lsm6dsl", {});
  sys.device("iio:device0", "bmp280", kBmp280);
  fs::create_directories(sys.root / "trigger0");
  fs::create_directories(sys.root / "iio:devicex");
  std::vector<IioDeviceEntry> all;
  std::string error;
  ASSERT_TRUE(list_iio_devices(sys.root.string(), all, error)) << error;
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].dir, sys.root.string() + "/iio:device0");
  EXPECT_EQ(all[0].name, "bmp280");
  EXPECT_EQ(all[1].name, "lsm6dsl");
  EXPECT_EQ(all[2].dir, sys.root.string() + "/iio:device10");
  EXPECT_EQ(all[2].name, "bmp388");
}

TEST(BaroIioDevices, FoundByName) {
  FakeSysfs sys;
  sys.device("iio:device0", "lsm6dsl", {});
  const std::string dir = sys.device("iio:device1", "bmp280", kBmp280);
  const IioLookup r = find_iio_device_by_name(sys.root.string(), "bmp280");
  EXPECT_EQ(r.kind, IioLookup::Kind::kFound);
  EXPECT_EQ(r.dir, dir);
}

TEST(BaroIioDevices, AnUnknownNameListsTheNamesFound) {
  FakeSysfs sys;
  sys.device("iio:device0", "lsm6dsl", {});
  sys.device("iio:device1", "bmp280", kBmp280);
  const std::string root = sys.root.string();
  const IioLookup r = find_iio_device_by_name(root, "bmp388");
  EXPECT_EQ(r.kind, IioLookup::Kind::kNotFound);
  EXPECT_EQ(r.reason, "no IIO device named 'bmp388' in " + root +
                          " (found: iio:device0 'lsm6dsl', iio:device1 'bmp280')");
  fs::remove_all(root + "/iio:device0");
  fs::remove_all(root + "/iio:device1");
  EXPECT_EQ(find_iio_device_by_name(root, "bmp388").reason,
            "no IIO device named 'bmp388' in " + root + " (there are none)");
  EXPECT_EQ(find_iio_device_by_name(root + "/nope", "bmp388").reason,
            "cannot read " + root +
                "/nope: No such file or directory (is the sensor's kernel driver loaded?)");
}

TEST(BaroIioDevices, TwoDevicesWithTheNameMustBeChosenByPath) {
  FakeSysfs sys;
  const std::string a = sys.device("iio:device0", "bmp280", kBmp280);
  const std::string b = sys.device("iio:device1", "bmp280", kBmp280);
  const IioLookup r = find_iio_device_by_name(sys.root.string(), "bmp280");
  EXPECT_EQ(r.kind, IioLookup::Kind::kAmbiguous);
  EXPECT_EQ(r.reason,
            "2 IIO devices are named 'bmp280' (" + a + ", " + b + "): pick one by its path");
}

TEST(BaroIioDevice, WritesThePressureOversamplingRatio) {
  FakeSysfs sys;
  IioDevice d;
  std::string error;
  const std::string dir =
      sys.device("iio:device0", "bmp280",
                 {{"in_pressure_input", "100\n"}, {"in_pressure_oversampling_ratio", "1\n"}});
  ASSERT_EQ(d.open(dir, error), IioDevice::OpenStatus::kOpen);
  ASSERT_TRUE(d.set_pressure_oversampling(16, error)) << error;
  EXPECT_EQ(FakeSysfs::read(dir + "/in_pressure_oversampling_ratio"), "16\n");
  fs::remove(dir + "/in_pressure_oversampling_ratio");
  EXPECT_FALSE(d.set_pressure_oversampling(16, error));
  EXPECT_EQ(error, dir +
                       " has no in_pressure_oversampling_ratio: the kernel driver of 'bmp280' "
                       "cannot set pressure oversampling");
  fs::create_directories(dir + "/in_pressure_oversampling_ratio");
  EXPECT_FALSE(d.set_pressure_oversampling(16, error));
  EXPECT_EQ(error, "in_pressure_oversampling_ratio: Is a directory");
}

// --- IioSensor ----------------------------------------------------------------------------

using PollKind = IioSensor::Poll::Kind;

IioSensorConfig by_name(const FakeSysfs& sys, const std::string& name) {
  IioSensorConfig c;
  c.id = "T1";
  c.root = sys.root.string();
  c.name = name;
  c.reopen_s = 1.0;
  return c;
}

TEST(BaroIioSensor, PublishesCheckedSamples) {
  FakeSysfs sys;
  const std::string dir = sys.device("iio:device0", "bmp280", kBmp280);
  IioSensor s(by_name(sys, "bmp280"));
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  EXPECT_EQ(s.selector(), "name 'bmp280'");
  auto p = s.poll(0.0);
  ASSERT_EQ(p.kind, PollKind::kSample) << p.text;
  EXPECT_FALSE(p.reopened);
  EXPECT_EQ(p.reading.temperature_c, 21.43);
  FakeSysfs::write(dir + "/in_pressure_input", "12.000000000\n");  // 12 kPa: implausible
  p = s.poll(0.1);
  EXPECT_EQ(p.kind, PollKind::kBad);
  EXPECT_EQ(p.text, "IIO device T1 (" + dir +
                        "): pressure 12000 Pa is outside 30..125 kPa, the measuring range of the "
                        "supported sensors");
  FakeSysfs::write(dir + "/in_pressure_input", "0\n");
  EXPECT_EQ(s.poll(0.2).text, "IIO device T1 (" + dir + "): pressure 0 Pa is not positive");
  FakeSysfs::write(dir + "/in_pressure_input", "101\n");
  FakeSysfs::write(dir + "/in_temp_input", "nan\n");
  EXPECT_EQ(s.poll(0.3).text, "IIO device T1 (" + dir + "): in_temp_input: 'nan' is not a number");
  EXPECT_TRUE(s.present());
}

TEST(BaroIioSensor, AVanishedDeviceIsReportedOnceAndFoundAgainByName) {
  FakeSysfs sys;
  const std::string dir = sys.device("iio:device0", "bmp280", kBmp280);
  IioSensor s(by_name(sys, "bmp280"));
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  ASSERT_EQ(s.poll(9.75).kind, PollKind::kSample);
  fs::remove_all(dir);
  auto p = s.poll(10.0);
  EXPECT_EQ(p.kind, PollKind::kGone);
  EXPECT_EQ(p.text, "IIO device T1 (" + dir +
                        ") gone: in_pressure_input: No such file or directory; retrying every 1 s");
  EXPECT_FALSE(s.present());
  EXPECT_EQ(s.poll(10.5).kind, PollKind::kNothing);   // before the retry
  EXPECT_EQ(s.poll(11.25).kind, PollKind::kNothing);  // "not there" was said when it went
  EXPECT_EQ(s.poll(12.5).kind, PollKind::kNothing);   // ... and stays said
  // It returns as another device number (module reloaded): the name finds it.
  const std::string again = sys.device("iio:device3", "bmp280", kBmp280);
  EXPECT_EQ(s.poll(13.0).kind, PollKind::kNothing);  // before the retry
  p = s.poll(13.5);
  EXPECT_EQ(p.kind, PollKind::kSample) << p.text;
  EXPECT_TRUE(p.reopened);
  EXPECT_EQ(p.reading.temperature_c, 21.43);
  EXPECT_EQ(s.device().dir(), again);
  p = s.poll(13.75);
  EXPECT_EQ(p.kind, PollKind::kSample);
  EXPECT_FALSE(p.reopened);
}

TEST(BaroIioSensor, ANewReasonWhileAwayIsReported) {
  FakeSysfs sys;
  const std::string dir = sys.device("iio:device0", "bmp280", kBmp280);
  IioSensor s(by_name(sys, "bmp280"));
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  fs::remove_all(dir);
  EXPECT_EQ(s.poll(1.0).kind, PollKind::kGone);
  EXPECT_EQ(s.poll(2.0).kind, PollKind::kNothing);
  const std::string a = sys.device("iio:device1", "bmp280", kBmp280);
  const std::string b = sys.device("iio:device2", "bmp280", kBmp280);
  auto p = s.poll(3.0);
  EXPECT_EQ(p.kind, PollKind::kMissing);
  EXPECT_EQ(p.text, "IIO device T1 not available: 2 IIO devices are named 'bmp280' (" + a + ", " +
                        b + "): pick one by its path; retrying every 1 s");
  EXPECT_EQ(s.poll(4.0).kind, PollKind::kNothing);  // the same reason again
  fs::remove_all(b);
  EXPECT_EQ(s.poll(5.0).kind, PollKind::kSample);
}

TEST(BaroIioSensor, ByPathUnderTheRootAndBack) {
  FakeSysfs sys;
  const std::string dir = sys.device("iio:device1", "bme280", kRawBme280);
  IioSensorConfig c = by_name(sys, "");
  c.id = "B1";
  c.path = "iio:device1";
  c.reopen_s = 0.2;
  IioSensor s(c);
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  EXPECT_EQ(s.selector(), "path " + dir);
  EXPECT_EQ(s.device().dir(), dir);
  EXPECT_EQ(s.poll(0.0).reading.humidity_pct, 45.2);
  fs::rename(dir, dir + ".away");
  auto p = s.poll(0.1);
  EXPECT_EQ(p.kind, PollKind::kGone);
  EXPECT_EQ(p.text, "IIO device B1 (" + dir +
                        ") gone: in_pressure_raw: No such file or directory; retrying every 0.2 s");
  EXPECT_EQ(s.poll(0.35).kind, PollKind::kNothing);
  fs::rename(dir + ".away", dir);
  p = s.poll(0.6);
  EXPECT_EQ(p.kind, PollKind::kSample);
  EXPECT_TRUE(p.reopened);
}

TEST(BaroIioSensor, ByTheI2cDeviceThatHoldsIt) {
  // /sys/bus/i2c/devices/1-0077 holds iio:deviceN: its bus address is stable, N is not.
  FakeSysfs sys;
  const std::string chip = (sys.root / "i2c" / "1-0077").string();
  sys.device("i2c/1-0077/iio:device4", "bmp280", kBmp280);
  IioSensorConfig c = by_name(sys, "");
  c.path = chip + "/";
  IioSensor s(c);
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  EXPECT_EQ(s.selector(), "path " + chip);
  EXPECT_EQ(s.device().dir(), chip + "/iio:device4");
  EXPECT_EQ(s.poll(0.0).kind, PollKind::kSample);
  fs::remove_all(chip + "/iio:device4");
  EXPECT_EQ(s.poll(0.25).kind, PollKind::kGone);
  EXPECT_EQ(s.poll(1.5).kind, PollKind::kNothing);  // "holds no IIO device": not there, quiet
  sys.device("i2c/1-0077/iio:device5", "bmp280", kBmp280);
  auto p = s.poll(2.75);
  EXPECT_EQ(p.kind, PollKind::kSample) << p.text;
  EXPECT_TRUE(p.reopened);
  EXPECT_EQ(s.device().dir(), chip + "/iio:device5");
  sys.device("i2c/1-0077/iio:device6", "bmp280", kBmp280);
  IioSensor two(c);
  EXPECT_FALSE(two.start(error));
  EXPECT_EQ(error, chip + " holds 2 IIO devices: give one of them");
  c.path = sys.root.string() + "/i2c";
  IioSensor none(c);
  EXPECT_FALSE(none.start(error));
  EXPECT_EQ(error, sys.root.string() + "/i2c holds no IIO device");
}

TEST(BaroIioSensor, StartUpErrors) {
  FakeSysfs sys;
  sys.device("iio:device0", "bmp280", kBmp280);
  sys.device("iio:device1", "bmp280", kBmp280);
  sys.device("iio:device2", "lsm6dsl", {});
  std::string error;
  IioSensor twice(by_name(sys, "bmp280"));
  EXPECT_FALSE(twice.start(error));
  EXPECT_NE(error.find("2 IIO devices are named 'bmp280'"), std::string::npos) << error;
  IioSensor unknown(by_name(sys, "bmp388"));
  EXPECT_FALSE(unknown.start(error));
  EXPECT_NE(error.find("no IIO device named 'bmp388'"), std::string::npos) << error;
  IioSensor accel(by_name(sys, "lsm6dsl"));
  EXPECT_FALSE(accel.start(error));
  EXPECT_NE(error.find("not a barometer"), std::string::npos) << error;
  IioSensorConfig c = by_name(sys, "");
  c.path = "iio:device0";
  c.oversampling = 8;
  IioSensor no_osr(c);
  EXPECT_FALSE(no_osr.start(error));
  EXPECT_EQ(error, sys.root.string() +
                       "/iio:device0 has no in_pressure_oversampling_ratio: the kernel driver of "
                       "'bmp280' cannot set pressure oversampling");
  EXPECT_FALSE(no_osr.present());
}

TEST(BaroIioSensor, OversamplingIsSetAgainWhenTheDeviceReturns) {
  FakeSysfs sys;
  auto attrs = kBmp280;
  attrs["in_pressure_oversampling_ratio"] = "1\n";
  const std::string dir = sys.device("iio:device0", "bmp280", attrs);
  IioSensorConfig c = by_name(sys, "bmp280");
  c.oversampling = 8;
  IioSensor s(c);
  std::string error;
  ASSERT_TRUE(s.start(error)) << error;
  EXPECT_EQ(FakeSysfs::read(dir + "/in_pressure_oversampling_ratio"), "8\n");
  fs::remove_all(dir);
  EXPECT_EQ(s.poll(0.0).kind, PollKind::kGone);
  sys.device("iio:device0", "bmp280", attrs);  // the driver's default again
  auto p = s.poll(1.0);
  EXPECT_EQ(p.kind, PollKind::kSample);
  EXPECT_TRUE(p.reopened);
  EXPECT_EQ(p.reopen_problem, "");
  EXPECT_EQ(FakeSysfs::read(dir + "/in_pressure_oversampling_ratio"), "8\n");
  fs::remove_all(dir);
  EXPECT_EQ(s.poll(2.0).kind, PollKind::kGone);
  sys.device("iio:device0", "bmp280", kBmp280);  // returns without the attribute
  p = s.poll(3.0);
  EXPECT_EQ(p.kind, PollKind::kSample);  // reading matters more than oversampling
  EXPECT_EQ(p.reopen_problem, "IIO device T1 (" + dir + "): " + dir +
                                  " has no in_pressure_oversampling_ratio: the kernel driver of "
                                  "'bmp280' cannot set pressure oversampling");
}

}  // namespace
}  // namespace ips::baro
