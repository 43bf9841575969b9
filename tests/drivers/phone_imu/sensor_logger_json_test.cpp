// Sensor Logger HTTP Push batches (drivers/phone_imu/sensor_logger_json.hpp); the shape from
// tszheichoi/awesome-sensor-logger PUSHING.md, time in epoch ns, values {x, y, z}.
#include "drivers/phone_imu/sensor_logger_json.hpp"

#include <gtest/gtest.h>

namespace ips::phone_imu {
namespace {

constexpr const char* kBatch = R"({"messageId": 3, "sessionId": "9a3c", "deviceId": "b7e2-41",
 "payload": [
  {"name": "accelerometer", "time": 1698501144401773000, "values": {"x": 0.06, "y": -0.001, "z": -0.1}},
  {"name": "totalacceleration", "time": 1698501144401773000, "values": {"z": 9.7, "y": 0.5, "x": 0.25}, "accuracy": 3},
  {"name": "gyroscope", "time": 1698501144399000000, "values": {"x": 0.01, "y": -0.02, "z": 0.5}},
  {"name": "magnetometer", "time": "1698501144390000000", "values": {"x": "21.5", "y": -3, "z": -40.25}},
  {"name": "location", "time": 1698501145514000000, "values": {"latitude": 50.1, "longitude": 14.4}},
  {"name": "orientation", "time": 1698501144401773000, "values": {"qx": 0, "qy": [1, {"a": null}], "qz": true}}
 ]})";

TEST(SensorLoggerJson, ReadsTotalAccelerationGyroscopeMagnetometer) {
  const JsonBatch b = parse_sensor_logger_batch(kBatch, {});
  ASSERT_TRUE(b.ok) << b.reason;
  EXPECT_EQ(b.device_id, "b7e2-41");
  EXPECT_EQ(b.other_entries, 3);  // accelerometer (without gravity), location, orientation
  EXPECT_EQ(b.bad_entries, 0);
  ASSERT_EQ(b.samples.size(), 3u);
  EXPECT_EQ(b.samples[0].kind, SensorKind::kAccel);
  EXPECT_EQ(b.samples[0].device_us, 1698501144401773);
  EXPECT_EQ(b.samples[0].xyz, (std::array<double, 3>{0.25, 0.5, 9.7}));
  EXPECT_EQ(b.samples[1].kind, SensorKind::kGyro);
  EXPECT_EQ(b.samples[1].xyz, (std::array<double, 3>{0.01, -0.02, 0.5}));
  EXPECT_EQ(b.samples[2].kind, SensorKind::kMag);
  EXPECT_EQ(b.samples[2].device_us, 1698501144390000);
  EXPECT_EQ(b.samples[2].xyz, (std::array<double, 3>{21.5, -3, -40.25}));
}

TEST(SensorLoggerJson, OtherNamesAndScales) {
  JsonSensorNames n;
  n.accel = "accelerometeruncalibrated";
  n.units.accel = kStandardGravity;  // iOS uncalibrated, "Standardise Units & Frames" off
  const JsonBatch b = parse_sensor_logger_batch(
      R"({"payload":[{"name":"accelerometeruncalibrated","time":5000,"values":{"x":0,"y":0,"z":-1}}]})",
      n);
  ASSERT_TRUE(b.ok) << b.reason;
  ASSERT_EQ(b.samples.size(), 1u);
  EXPECT_EQ(b.samples[0].device_us, 5);
  EXPECT_DOUBLE_EQ(b.samples[0].xyz[2], -9.80665);
  EXPECT_EQ(b.device_id, "");
}

TEST(SensorLoggerJson, MalformedEntriesAreSkippedAndCounted) {
  const JsonBatch b = parse_sensor_logger_batch(R"({"payload":[
    {"name":"gyroscope","values":{"x":1,"y":2,"z":3}},
    {"name":"gyroscope","time":1,"values":{"x":1,"y":2}},
    {"name":"gyroscope","time":-5,"values":{"x":1,"y":2,"z":3}},
    {"name":"gyroscope","time":1.5e30,"values":{"x":1,"y":2,"z":3}},
    {"name":"gyroscope","time":"12a","values":{"x":1,"y":2,"z":3}},
    {"name":"gyroscope","time":null,"values":{"x":1,"y":2,"z":3}},
    {"name":"gyroscope","time":1,"values":[1,2,3]},
    {"name":"gyroscope","time":1,"values":{"x":"nan","y":2,"z":3}},
    {"name":"gyroscope","time":1},
    {"name":"gyroscope","time":7000,"values":{"x":1,"y":2,"z":3}}]})",
                                                 {});
  ASSERT_TRUE(b.ok) << b.reason;
  EXPECT_EQ(b.bad_entries, 9);
  EXPECT_EQ(b.first_bad, "gyroscope: no time");
  ASSERT_EQ(b.samples.size(), 1u);
  EXPECT_EQ(b.samples[0].device_us, 7);
  const std::pair<const char*, const char*> firsts[] = {
      {R"({"payload":[{"name":"gyroscope","time":1,"values":{"x":1,"y":2}}]})",
       "gyroscope: values lack x, y or z"},
      {R"({"payload":[{"name":"gyroscope","time":-5,"values":{"x":1,"y":2,"z":3}}]})",
       "gyroscope: time '-5' is not epoch nanoseconds"},
      {R"({"payload":[{"name":"gyroscope","time":null,"values":{}}]})",
       "gyroscope: time is not a number"},
      {R"({"payload":[{"name":"gyroscope","time":1,"values":[1]}]})",
       "gyroscope: values is not an object"},
      {R"({"payload":[{"name":"gyroscope","time":1,"values":{"x":"nan","y":2,"z":3}}]})",
       "gyroscope: values.x is not a finite number"},
      {R"({"payload":[{"name":"gyroscope","time":1}]})", "gyroscope: no values"},
  };
  for (const auto& [body, why] : firsts) EXPECT_EQ(parse_sensor_logger_batch(body, {}).first_bad, why);
}

TEST(SensorLoggerJson, BodiesThatAreRefused) {
  const std::pair<std::string, const char*> cases[] = {
      {"", "body is not a JSON object"},
      {"[1,2]", "body is not a JSON object"},
      {"{\"deviceId\":\"a\"}", "no payload array"},
      {"{\"payload\":{}}", "not JSON: payload is not an array"},
      {"{\"payload\":[1]}", "not JSON: a payload entry is not an object"},
      {"{\"payload\":[]", "not JSON: expected '}' at byte 13"},
      {"{\"payload\":[]} x", "bytes after the JSON object"},
      {"{\"payload\":[], \"a\": 01}", "not JSON: leading zero in a number at byte 22"},
      {"{\"payload\":[], \"a\": \"x\ty\"}", "not JSON: control character in a string at byte 23"},
      {"{\"payload\":[], \"a\": \"\\q\"}", "not JSON: bad escape in a string at byte 23"},
      {"{\"payload\":[], \"a\": tru}", "not JSON: expected a value at byte 20"},
      {"{\"payload\":[], \"a\": " + std::string(40, '[') + std::string(40, ']') + "}",
       "not JSON: nesting deeper than 32 at byte 52"},
      {"{\"deviceId\":\"" + std::string(300, 'a') + "\",\"payload\":[]}",
       "not JSON: string longer than 256 bytes at byte 270"},
  };
  for (const auto& [body, why] : cases) {
    const JsonBatch b = parse_sensor_logger_batch(body, {});
    EXPECT_FALSE(b.ok) << body;
    EXPECT_EQ(b.reason, why) << body;
    EXPECT_TRUE(b.samples.empty());
  }
}

TEST(SensorLoggerJson, EscapesInStrings) {
  const JsonBatch b = parse_sensor_logger_batch(
      R"({"deviceId":"a\u0041\n\u00e9","payload":[{"name":"gyr\u006fscope","time":1000,"values":{"x":1,"y":2,"z":3}}]})",
      {});
  ASSERT_TRUE(b.ok) << b.reason;
  EXPECT_EQ(b.device_id, "aA\n?");
  EXPECT_EQ(b.samples.size(), 1u);
}

}  // namespace
}  // namespace ips::phone_imu
