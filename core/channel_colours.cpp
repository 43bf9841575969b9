#include "core/channel_colours.hpp"

#include <array>
#include <cstdint>
#include <set>

#include "core/channels.hpp"

namespace ips {
namespace {

struct FixedColour {
  std::string_view channel, colour;
};

// Tableau 10 for the default channel names (TRUTH black; POSE_UWB_EPOCH, the naive per-epoch
// fixes beside the UWB tracker, the light blue of POSE_UWB's pair). ALTITUDE (altitude_t, not a
// pose) has one too, for the figures that draw heights.
constexpr std::array<FixedColour, 11> kFixed = {{
    {channel::kTruth, "#000000"},
    {channel::kPoseUwb, "#1f77b4"},
    {channel::kPoseTdoa, "#ff7f0e"},
    {channel::kPoseAoa, "#2ca02c"},
    {channel::kPoseFused, "#d62728"},
    {channel::kPoseIns, "#9467bd"},
    {channel::kPosePdr, "#8c564b"},
    {channel::kInsModule, "#17becf"},
    {channel::kPoseUwbModule, "#bcbd22"},
    {channel::kPoseUwbEpoch, "#aec7e8"},
    {channel::kAltitude, "#e377c2"},
}};

// Tableau 10's grey, the one colour of it no default channel has, then the rest of Tableau 20's
// light half.
constexpr std::array<std::string_view, 9> kOthers = {"#7f7f7f", "#ffbb78", "#98df8a",
                                                     "#ff9896", "#c5b0d5", "#c49c94",
                                                     "#f7b6d2", "#dbdb8d", "#9edae5"};

const FixedColour* fixed(std::string_view channel) {
  for (const auto& f : kFixed)
    if (f.channel == channel) return &f;
  return nullptr;
}

// FNV-1a (32 bit): stable across programs, runs and platforms, unlike std::hash.
size_t other_index(std::string_view channel) {
  uint32_t h = 2166136261u;
  for (const char c : channel) {
    h ^= static_cast<unsigned char>(c);
    h *= 16777619u;
  }
  return h % kOthers.size();
}

}  // namespace

std::string channel_colour(std::string_view channel) {
  if (const FixedColour* f = fixed(channel)) return std::string(f->colour);
  return std::string(kOthers[other_index(channel)]);
}

std::map<std::string, std::string> channel_colours(const std::vector<std::string>& channels) {
  std::map<std::string, std::string> colours;
  const std::set<std::string> sorted(channels.begin(), channels.end());
  std::set<size_t> used;  // indices into kOthers
  std::vector<std::string> collided;
  for (const auto& c : sorted) {
    if (const FixedColour* f = fixed(c)) {
      colours[c] = std::string(f->colour);
    } else if (used.insert(other_index(c)).second) {
      colours[c] = std::string(kOthers[other_index(c)]);
    } else {
      collided.push_back(c);
    }
  }
  // Second pass, so a collision never takes the hash colour of a name later in the order.
  for (const auto& c : collided) {
    size_t i = other_index(c);
    for (size_t step = 0; step < kOthers.size(); ++step) {
      const size_t j = (other_index(c) + step) % kOthers.size();
      if (!used.count(j)) {
        i = j;
        break;
      }
    }
    used.insert(i);
    colours[c] = std::string(kOthers[i]);
  }
  return colours;
}

}  // namespace ips
