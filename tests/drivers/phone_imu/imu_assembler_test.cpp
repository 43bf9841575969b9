// Readings to imu_t (drivers/phone_imu/imu_assembler.hpp, phone_streams.hpp).
#include "drivers/phone_imu/imu_assembler.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "drivers/phone_imu/phone_streams.hpp"

namespace ips::phone_imu {
namespace {

SensorSample s(SensorKind k, int64_t t, double v) { return {k, t, {v, v + 1, v + 2}}; }

std::vector<AssembledImu> run(ImuAssembler& a, std::vector<SensorSample> batch,
                              int64_t* dropped = nullptr) {
  std::vector<AssembledImu> out;
  const int64_t d = a.add_batch(batch, [&](const AssembledImu& m) { out.push_back(m); });
  if (dropped) *dropped = d;
  return out;
}

TEST(ImuAssembler, EachAccelCarriesTheLatestRecentGyroAndMag) {
  ImuAssembler a;  // window 50 ms
  // A Sensor Logger batch: grouped by sensor, not in time order.
  const auto out = run(a, {s(SensorKind::kAccel, 10'000, 1), s(SensorKind::kAccel, 20'000, 2),
                           s(SensorKind::kAccel, 200'000, 3), s(SensorKind::kGyro, 8'000, 10),
                           s(SensorKind::kGyro, 20'000, 20), s(SensorKind::kMag, 0, 30)});
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].device_us, 10'000);
  EXPECT_EQ(out[0].accel[0], 1);
  EXPECT_EQ(out[0].gyro[0], 10);
  EXPECT_EQ(out[0].mag[0], 30);
  // Same time: the gyroscope reading goes first.
  EXPECT_EQ(out[1].gyro[0], 20);
  // 180 ms after the last gyroscope and 200 ms after the magnetometer: absent.
  EXPECT_TRUE(std::isnan(out[2].gyro[0]) && std::isnan(out[2].gyro[2]));
  EXPECT_TRUE(std::isnan(out[2].mag[1]));
}

TEST(ImuAssembler, StaleOrRepeatedAccelIsDropped) {
  ImuAssembler a;
  int64_t dropped = 0;
  EXPECT_EQ(run(a, {s(SensorKind::kAccel, 100, 1)}).size(), 1u);
  EXPECT_TRUE(run(a, {s(SensorKind::kAccel, 100, 1), s(SensorKind::kAccel, 50, 1)}, &dropped)
                  .empty());
  EXPECT_EQ(dropped, 2);
  a.reset();
  EXPECT_EQ(run(a, {s(SensorKind::kAccel, 50, 1)}).size(), 1u);
}

TEST(ImuAssembler, PerSampleModeOneMessagePerReading) {
  ImuAssembler a({.per_sample = true, .window_us = 0});
  const auto out = run(a, {s(SensorKind::kMag, 5, 7), s(SensorKind::kGyro, 5, 3)});
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].gyro[2], 5);
  EXPECT_TRUE(std::isnan(out[0].accel[0]) && std::isnan(out[0].mag[0]));
  EXPECT_EQ(out[1].mag[0], 7);
  EXPECT_TRUE(std::isnan(out[1].gyro[1]));
}

TEST(PhoneStreams, MapsPhoneTimeAndKeepsDevicesApart) {
  std::vector<imu_t> out;
  PhoneStreams streams({.source = "test", .assembler = {}, .clock = {}, .fixed_offset_us = {},
                        .max_devices = 2},
                       [&](const imu_t& m) { out.push_back(m); });
  const int64_t host = 1'700'000'000'000'000;
  std::vector<SensorSample> b{s(SensorKind::kGyro, 890'715'580, 0.5),
                              s(SensorKind::kAccel, 890'715'580, 9)};
  BatchResult r = streams.on_batch("10.0.0.7", host, b);
  EXPECT_EQ(r.published, 1);
  EXPECT_EQ(r.offset_us, host - 890'715'580);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, host);
  EXPECT_EQ(out[0].device_utime, 890'715'580);
  EXPECT_EQ(out[0].device_id, "10.0.0.7");
  EXPECT_EQ(out[0].source, "test");
  EXPECT_EQ(out[0].gyro[1], 1.5);
  EXPECT_TRUE(std::isnan(out[0].mag_ut[0]));
  // 20 ms later, delayed 30 ms: mapped with the first reading's (smaller) offset.
  b = {s(SensorKind::kAccel, 890'735'580, 1)};
  streams.on_batch("10.0.0.7", host + 50'000, b);
  EXPECT_EQ(out.back().utime, host + 20'000);
  // Three devices with a limit of two: the least recent is forgotten.
  b = {s(SensorKind::kAccel, 1, 1)};
  streams.on_batch("b", host, b);
  b = {s(SensorKind::kAccel, 1, 1)};
  streams.on_batch("c", host, b);
  EXPECT_EQ(streams.devices(), 2u);
}

TEST(PhoneStreams, FixedOffsetAndImplausibleTimesDropped) {
  std::vector<imu_t> out;
  PhoneStreamsConfig c;
  c.fixed_offset_us = 0;
  PhoneStreams streams(c, [&](const imu_t& m) { out.push_back(m); });
  std::vector<SensorSample> b{s(SensorKind::kAccel, 0, 1), s(SensorKind::kAccel, 5, 1)};
  const BatchResult r = streams.on_batch("phone", 0, b);
  EXPECT_EQ(r.dropped, 1);  // utime 0 is not a plausible time
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, 5);
}

}  // namespace
}  // namespace ips::phone_imu
