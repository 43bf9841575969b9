#include "core/site_edit.hpp"

namespace ips {

SiteYamlEdit::SiteYamlEdit(const Site& site) {
  try {
    root_ = YAML::Load(site.yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError("the input site's YAML does not parse: " + std::string(e.what()));
  }
  if (!root_.IsMap()) throw ConfigError("the input site's YAML is not a map");
}

YAML::Node SiteYamlEdit::map_at(const std::vector<std::string>& keys) {
  YAML::Node node = root_;
  std::string path;
  for (const auto& key : keys) {
    path += (path.empty() ? "" : ".") + key;
    YAML::Node child = node[key];
    if (!child.IsMap()) {
      if (child.IsDefined() && !child.IsNull())
        throw ConfigError("the input site's " + path + " is not a map");
      node[key] = YAML::Node(YAML::NodeType::Map);
    }
    // yaml-cpp's Node::operator= assigns through; reset() rebinds.
    node.reset(node[key]);
  }
  return node;
}

std::string SiteYamlEdit::text(const std::vector<std::string>& header) const {
  YAML::Emitter out;
  out << root_;
  std::string text;
  for (const auto& line : header) text += "# " + line + "\n";
  text += out.c_str();
  text += "\n";
  try {
    parse_site_text(text, "the edited site");
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("the edited site does not parse back: ") + e.what());
  }
  return text;
}

}  // namespace ips
