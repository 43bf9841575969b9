#pragma once
// One colour per pose channel in every program (ips-view's map and live page, ips-eval's
// report): a fixed colour for each default channel name (and ALTITUDE), TRUTH black and the
// estimators in Tableau 10 (distinct for the common kinds of colour blindness), and for any other
// name a colour of the lighter Tableau 20 half picked by a hash of the name. A colour depends only
// on the channel's own name, never on which other channels are in the log or on the bus, so
// POSE_FUSED is red in the viewer and in the report alike.
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace ips {

// The colour of one channel ("#rrggbb"): its fixed colour, else the palette entry of its name's
// FNV-1a hash.
std::string channel_colour(std::string_view channel);

// The colour of each of `channels` (duplicates once): channel_colour(), except where two names
// outside the fixed table hash to the same colour; then the later one in sorted order takes the
// next colour of the palette not yet used by another of `channels` (while the palette lasts), so
// the channels of one figure stay apart.
std::map<std::string, std::string> channel_colours(const std::vector<std::string>& channels);

}  // namespace ips
