#pragma once
// The values of Linux IIO sysfs attributes, as text (what a read of the file gives), and the
// value of one IIO channel from its attributes. Pure: no I/O, never throws.
//
// IIO sysfs ABI (Linux Documentation/ABI/testing/sysfs-bus-iio):
//  - in_pressure_input: "Scaled pressure measurement ..., in kilopascal"; in_pressure_raw:
//    "Units after application of scale and offset are kilopascal".
//  - in_temp_input: "Scaled temperature measurement in milli degrees Celsius"; in_temp_raw: the
//    same units after scale and offset.
//  - in_humidityrelative_input: "Scaled humidity measurement in milli percent".
//  - <type>_offset: "offset to be added to <type>[Y]_raw prior to scaling by <type>[Y]_scale";
//    "Not present if the offset is always 0 or unknown".
// So value = (raw + offset) * scale, in the units of _input.
//
// The kernel prints these (iio_format_value) as an integer ("-12345", IIO_VAL_INT) or a plain
// decimal ("101.325120000", IIO_VAL_INT_PLUS_NANO; "0.000976562", IIO_VAL_FRACTIONAL), then a
// newline: never an exponent, never nan.
#include <optional>
#include <string>
#include <string_view>

namespace ips::baro {

// True and `value` set when `text` (surrounding blanks and newlines ignored) is a finite integer
// or plain decimal; otherwise false with the reason (the text quoted).
bool parse_sysfs_number(std::string_view text, double& value, std::string& reason);

// The texts read from one channel's attributes. `prefix` names the channel ("in_pressure") for
// the reasons. Either `input`, or `raw` with `scale` and optionally `offset`.
struct IioChannelText {
  std::string_view prefix;
  std::optional<std::string_view> input, raw, scale, offset;
};

// The channel's value in the unit of its _input: _input as it is, else (raw + offset) * scale.
// False with the reason (naming the attribute) when a text is not a number, the result is not
// finite, or the channel has neither _input nor _raw with _scale.
bool iio_channel_value(const IioChannelText& channel, double& value, std::string& reason);

}  // namespace ips::baro
