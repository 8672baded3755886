#include "densemap/sources/source_option_table.h"

#include "densemap/ros2/frame_option_table.h"

namespace densemap::sources {

options::OptionTable sourceOptionTable(SourceSelection& s) {
  options::OptionTable t("Scan source");
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
  ros2::addFrameOptions(t, s.options.frames);
  return t;
}

}  // namespace densemap::sources
