#include "support/device.hpp"

namespace cansim::test {

config::Profile prepared_repo_profile(const std::string& name, const std::function<void(config::Profile&)>& edit) {
  config::Profile profile = load_repo_profile(name);
  if (edit) {
    profile.options = std::make_shared<NodeOptions>(*profile.options);
    edit(profile);
  }
  return profile;
}

config::Profile prepared_repo_yaml(const std::string& name, const std::function<void(YAML::Node&)>& edit) {
  const std::string path = std::string(CANSIM_SOURCE_DIR) + "/profiles/" + name + ".yaml";
  YAML::Node root = YAML::LoadFile(path);
  if (edit) edit(root);
  return config::parse_profile(root, path);
}

std::string load_error(const std::string& text, const std::string& file) {
  try {
    config::parse_profile(text, file);
  } catch (const config::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

std::string repo_yaml_error(const std::string& name, const std::function<void(YAML::Node&)>& edit) {
  try {
    prepared_repo_yaml(name, edit);
  } catch (const config::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

std::vector<Sent> only(const std::vector<Sent>& frames, std::uint32_t id) {
  std::vector<Sent> out;
  for (const Sent& s : frames)
    if (s.frame.id == id) out.push_back(s);
  return out;
}

CanFrame answer(const std::vector<Sent>& frames, std::uint32_t id) {
  for (const Sent& s : frames)
    if (s.frame.id == id) return s.frame;
  return CanFrame{};
}

std::vector<CanFrame> frames(const std::vector<Sent>& sent) {
  std::vector<CanFrame> out;
  for (const Sent& s : sent) out.push_back(s.frame);
  return out;
}

std::string expected(TimeUs t0, std::initializer_list<At> list) {
  std::vector<Sent> v;
  for (const At& a : list) v.push_back({t0 + a.dt, a.frame});
  return to_string(v);
}

std::vector<CanFrame> sdo_aborted(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub, std::uint32_t code) {
  return one(0x580u + node_id, {0x80, std::uint8_t(index), std::uint8_t(index >> 8), sub, std::uint8_t(code),
                                std::uint8_t(code >> 8), std::uint8_t(code >> 16), std::uint8_t(code >> 24)});
}

std::vector<CanFrame> sdo_confirmed(std::uint8_t node_id, std::uint16_t index, std::uint8_t sub) {
  return one(0x580u + node_id, {0x60, std::uint8_t(index), std::uint8_t(index >> 8), sub, 0, 0, 0, 0});
}

}  // namespace cansim::test
