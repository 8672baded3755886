#include "densemap/cli/common_options.h"

namespace densemap::cli {

OptionTable sourceOptions(SourceSelection& s) {
  OptionTable t("Scan source");
  t.add(
      "source", s.source,
      "'sim[:key=value,...]' (built-in simulator), a sequence directory (clouds/ + poses/), a KITTI odometry "
      "layout (velodyne/ + poses.txt + calib.txt), a directory of <name>_<k>.pcd with VIEWPOINT origins "
      "(la3dm), "
      "one .pcd, an OctoMap .graph, or a ROS 2 bag (.mcap, .db3, or a rosbag2 directory)");
  t.add("scans", s.scans, "scan range FIRST:LAST (inclusive), N, or FIRST: (to the end); empty: all");
  t.add("allow-gaps", s.options.allow_gaps,
        "map the scans a numbered sequence holds when some files are missing, or a bag's clouds that have "
        "a transform (default: a gap is an error)");
  addFrameOptions(t, s.options.frames);
  return t;
}

void addFrameOptions(OptionTable& t, ros2::FrameOptions& f) {
  t.add("cloud-topic", f.cloud_topic,
        "ROS 2 sensor_msgs/PointCloud2 topic (bags: default their only one; the server's ROS 2 edge: "
        "/cloud_in)");
  t.add("frame-id", f.fixed_frame, "ROS 2 fixed frame the map is built in (octomap_server's frame_id)");
  t.add("base-frame-id", f.base_frame,
        "ROS 2 robot base frame: the child of a PoseStamped pose topic (octomap_server's base_frame_id)");
  t.add("pose-topic", f.pose_topic,
        "ROS 2 nav_msgs/Odometry or geometry_msgs/PoseStamped topic giving the base pose (default: use /tf)");
}

OptionTable loggingOptions(std::string& level) {
  OptionTable t("Logging");
  t.add("log-level", level, "how much to log")
      .oneOf({"trace", "debug", "info", "warn", "error", "critical", "off"});
  return t;
}

OptionTable mapOptions(map::MapOptions& o) {
  OptionTable t("Map");
  t.add("backend", o.backend, "grid (hashed 16^3 blocks, fastest) or octree (OctoMap's OcTree)")
      .oneOf({"grid", "octree"});
  t.add("resolution", o.resolution, "voxel edge in metres").range(0.001, 100.0);
  t.add("prob-hit", o.params.prob_hit, "P(occupied) of a cell holding an endpoint").range(0.5, 1.0);
  t.add("prob-miss", o.params.prob_miss, "P(occupied) of a cell a ray crosses").range(0.0, 0.5);
  t.add("clamp-min", o.params.clamp_min, "lower clamping probability (Sec. 2.2.1)").range(0.0, 1.0);
  t.add("clamp-max", o.params.clamp_max, "upper clamping probability").range(0.0, 1.0).checkedBy([&o] {
    return o.params.validate();
  });
  t.add("decay-s", o.decay.seconds_to_unknown,
        "decay (grid only): seconds without observations for a cell at the upper clamp to become unknown; "
        "every known cell relaxes toward unknown at clamp-max's log-odds over this time (0: off, the "
        "OctoMap-equal map)")
      .range(0.0, 1e7);
  t.add("decay-step-s", o.decay.step_s,
        "decay is applied in steps of this much map time (the scans' receive times in the server)")
      .range(0.01, 3600.0)
      .checkedBy([&o] {
        if (o.decay.enabled() && o.backend != "grid") return std::string("--decay-s needs --backend grid");
        return o.decay.validate();
      });
  return t;
}

OptionTable kernelLayerOptions(dense::DenseLayerOptions& o) {
  OptionTable t("Kernel layers (Ch. 3): AKIMap and BGK");
  t.add("dense-free-sample-distance", o.free_sample_distance, "one free sample per this many metres of ray")
      .range(0.001, 100.0);
  t.add("dense-free-voxel", o.free_voxel_size,
        "one free sample per voxel of this size (0: the dense resolution)")
      .range(0.0, 100.0);
  t.add("dense-min-search-radius", o.min_search_radius,
        "AKIMap: floor of every sample's neighbour search radius in metres (0: the dissertation's schedule)")
      .range(0.0, 100.0);
  t.add("akimap-preset", o.akimap_preset,
        "AKIMap's settings: measured (isotropic free kernels and a 0.3 m occupied radius floor, the best "
        "measured: above BGK on both la3dm scenes) or dissertation (Ch. 3 as it stands); the two "
        "options below override it when given")
      .oneOf({"measured", "dissertation"});
  OptionSpec& iso = t.add("dense-isotropic-free", o.isotropic_free_kernels,
                          "AKIMap: isotropic kernels for free samples (default: from --akimap-preset)")
                        .exampleOnly();  // a configuration file that sets it would override the preset
  OptionSpec& floor = t.add("dense-min-occupied-radius", o.min_occupied_search_radius,
                            "AKIMap: floor of occupied samples' search radius in metres (default: from "
                            "--akimap-preset; 0: the dissertation's)")
                          .range(0.0, 100.0)
                          .exampleOnly();
  // The preset sets what the user did not; given values win (the deque keeps these references valid).
  t.afterParse([&o, &iso, &floor] {
    const bool iso_value = o.isotropic_free_kernels;
    const double floor_value = o.min_occupied_search_radius;
    o.applyAkimapPreset(o.akimap_preset);
    if (iso.given) o.isotropic_free_kernels = iso_value;
    if (floor.given) o.min_occupied_search_radius = floor_value;
  });
  return t;
}

OptionTable updateOptions(update::UpdateOptions& o) {
  OptionTable t("Update (Ch. 2)");
  t.addChoice(
      "method", o.method,
      {{"fastest", update::UpdateMethod::kFastest},
       {"baseline", update::UpdateMethod::kBaseline},
       {"superrays", update::UpdateMethod::kSuperRays},
       {"culling", update::UpdateMethod::kCullingRegion},
       {"superrays+culling", update::UpdateMethod::kSuperRaysCulling}},
      "update method; all give the same map (super rays Sec. 2.3.1-2.3.4, culling region Sec. 2.3.5). "
      "fastest: the baseline, unless the scans are dense enough for super rays to save walking (then per "
      "scan whichever of the four is measured fastest so far)");
  t.addChoice("semantics", o.semantics,
              {{"batch", map::UpdateSemantics::kBatch}, {"counting", map::UpdateSemantics::kCounting}},
              "batch (OctoMap's insertPointCloud) or counting (Sec. 2.3.4)");
  t.add("max-range", o.max_range, "cut rays at this range in metres (< 0: unlimited)").range(-1.0, 1e5);
  return t;
}

}  // namespace densemap::cli
