#include "densemap/server/ros2_edge/octomap_params.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <variant>

namespace densemap::server::ros2_edge {

namespace {

/// Parameters as flat names ("sensor_model.max_range"; ROS 1's '/' separator accepted too).
void flatten(const YAML::Node& node, const std::string& prefix, std::map<std::string, YAML::Node>& out,
             int depth = 0) {
  if (depth > 16) throw std::invalid_argument("parameters nested deeper than 16 levels");
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) throw std::invalid_argument("a parameter name that is not a plain name");
    std::string key = kv.first.as<std::string>();
    for (char& c : key)
      if (c == '/') c = '.';
    const std::string name = prefix.empty() ? key : prefix + "." + key;
    if (kv.second.IsMap())
      flatten(kv.second, name, out, depth + 1);
    else
      out[name] = kv.second;
  }
}

// octomap_server's parameters that densemap does not implement: a warning each.
const std::set<std::string> kNotImplemented = {"filter_ground",
                                               "ground_filter.distance",
                                               "ground_filter.angle",
                                               "ground_filter.plane_distance",
                                               "filter_speckles",
                                               "colored_map",
                                               "color_factor",
                                               "height_map",
                                               "color.r",
                                               "color.g",
                                               "color.b",
                                               "color.a",
                                               "color_free.r",
                                               "color_free.g",
                                               "color_free.b",
                                               "color_free.a",
                                               "compress_map",
                                               "incremental_2D_projection",
                                               "publish_free_space",
                                               "sensor_model.min_range",
                                               "track_changes",
                                               "listen_changes",
                                               "min_x_size",
                                               "min_y_size",
                                               "point_cloud_min_x",
                                               "point_cloud_max_x",
                                               "point_cloud_min_y",
                                               "point_cloud_max_y",
                                               "use_height_map",
                                               "max_depth",
                                               "change_id_frame"};

}  // namespace

std::vector<std::string> applyOctomapParamsText(const std::string& yaml, const std::string& name,
                                                const std::string& node_name, const OctomapParamTargets& t,
                                                const std::function<bool(const std::string& flag)>& given) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(name + ": not YAML (" + e.what() + ")");
  }
  if (!root.IsMap())
    throw std::invalid_argument(name + ": not a ROS 2 parameters file (<node>: ros__parameters: ...)");
  std::map<std::string, YAML::Node> params;
  bool found = false;
  // The wildcard first, so the node's own section wins.
  try {
    for (const std::string& section : {std::string("/**"), node_name, "/" + node_name}) {
      const YAML::Node s = root[section];
      if (!s) continue;
      if (!s.IsMap() || !s["ros__parameters"] || !s["ros__parameters"].IsMap())
        throw std::invalid_argument("section '" + section + "' has no ros__parameters map");
      flatten(s["ros__parameters"], "", params);
      found = true;
    }
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(name + ": not a ROS 2 parameters file (" + e.what() + ")");
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(name + ": " + e.what());
  }
  if (!found)
    throw std::invalid_argument(name + ": no section for node '" + node_name +
                                "' (nor '/**'); set --node-name to the "
                                "node the file configures");

  using Target = std::variant<double*, std::string*, bool*>;
  struct Binding {
    const char* flag;
    Target target;
  };
  std::map<std::string, Binding> bindings;
  if (t.map) {
    bindings.emplace("resolution", Binding{"resolution", &t.map->resolution});
    bindings.emplace("sensor_model.hit", Binding{"prob-hit", &t.map->params.prob_hit});
    bindings.emplace("sensor_model.miss", Binding{"prob-miss", &t.map->params.prob_miss});
    bindings.emplace("sensor_model.min", Binding{"clamp-min", &t.map->params.clamp_min});
    bindings.emplace("sensor_model.max", Binding{"clamp-max", &t.map->params.clamp_max});
  }
  // octomap_server's max_range < 0 means unlimited, as densemap's.
  if (t.update) bindings.emplace("sensor_model.max_range", Binding{"max-range", &t.update->max_range});
  if (t.ros2) {
    bindings.emplace("frame_id", Binding{"frame-id", &t.ros2->frames.fixed_frame});
    bindings.emplace("base_frame_id", Binding{"base-frame-id", &t.ros2->frames.base_frame});
    bindings.emplace("latch", Binding{"latch", &t.ros2->latch});
    bindings.emplace("occupancy_min_z", Binding{"occupancy-min-z", &t.ros2->occupancy_min_z});
    bindings.emplace("occupancy_max_z", Binding{"occupancy-max-z", &t.ros2->occupancy_max_z});
    for (const char* p : {"pointcloud_min_z", "point_cloud_min_z"})
      bindings.emplace(p, Binding{"pointcloud-min-z", &t.ros2->pointcloud_min_z});
    for (const char* p : {"pointcloud_max_z", "point_cloud_max_z"})
      bindings.emplace(p, Binding{"pointcloud-max-z", &t.ros2->pointcloud_max_z});
  }
  std::vector<std::string> ignored;
  // Every value is converted before any is set: a file with one wrong value changes nothing.
  std::vector<std::function<void()>> assignments;
  for (const auto& [param, value] : params) {
    auto b = bindings.find(param);
    if (b == bindings.end()) {
      if (param == "use_sim_time") continue;  // every node has it; densemap uses the stamps it receives
      ignored.push_back(param + (kNotImplemented.count(param)
                                     ? ": an octomap_server feature densemap does not have"
                                     : ": not an octomap_server parameter densemap knows"));
      continue;
    }
    if (given(b->second.flag)) continue;  // the command line wins
    const YAML::Node& node = value;
    try {
      std::visit(
          [&](auto* target) {
            using T = std::remove_pointer_t<decltype(target)>;
            T converted = node.as<T>();
            assignments.push_back([target, converted] { *target = converted; });
          },
          b->second.target);
    } catch (const YAML::Exception&) {
      std::ostringstream v;
      v << node;
      throw std::invalid_argument(name + ": parameter " + param + " = '" + v.str() + "' is not a " +
                                  (std::holds_alternative<double*>(b->second.target) ? "number"
                                   : std::holds_alternative<bool*>(b->second.target) ? "bool"
                                                                                     : "string"));
    }
  }
  for (const auto& assign : assignments) assign();
  return ignored;
}

std::vector<std::string> applyOctomapParams(const std::string& path, const std::string& node_name,
                                            const OctomapParamTargets& targets,
                                            const std::function<bool(const std::string& flag)>& given) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("--params-file " + path + ": cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  if (text.str().size() > (1u << 20))
    throw std::invalid_argument("--params-file " + path + ": larger than 1 MB");
  return applyOctomapParamsText(text.str(), path, node_name, targets, given);
}

}  // namespace densemap::server::ros2_edge
