// ROS 2's graph over DDS: every ROS 2 participant publishes rmw_dds_common/msg/ParticipantEntitiesInfo on
// `ros_discovery_info` (reliable, transient local, keep last 1), naming its nodes and each node's readers
// and writers by GID. `ros2 node list` and `ros2 topic info` read it; a participant that does not publish it
// has no nodes in ROS 2's eyes. Written from the published definitions:
//   Gid:                     uint8[24] data (Humble) or uint8[16] data (Jazzy), same type name
//   NodeEntitiesInfo:        string<256> node_namespace, string<256> node_name, Gid[] reader_gid_seq,
//                            Gid[] writer_gid_seq
//   ParticipantEntitiesInfo: Gid gid, NodeEntitiesInfo[] node_entities_info_seq
// A Fast DDS entity's GID is its 16-byte GUID (prefix and entity id), zero-padded to the Gid's size.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace densemap::ros2 {

inline constexpr const char* kDiscoveryInfoTopic = "ros_discovery_info";
inline constexpr const char* kDiscoveryInfoType = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";

/// The ROS 2 distribution whose Gid layout to write: Humble (24 bytes, also Iron) or Jazzy (16 bytes).
enum class RosDistribution { kHumble, kJazzy };
[[nodiscard]] std::size_t gidBytes(RosDistribution distribution);
/// "humble" / "jazzy"; throws std::invalid_argument naming the choices for anything else.
[[nodiscard]] RosDistribution parseRosDistribution(const std::string& name);

using Guid = std::array<std::uint8_t, 16>;

struct NodeEntities {
  std::string node_namespace = "/";
  std::string node_name;
  std::vector<Guid> readers;
  std::vector<Guid> writers;
};

struct ParticipantEntities {
  Guid participant{};
  std::vector<NodeEntities> nodes;
};

[[nodiscard]] std::vector<std::uint8_t> encode(const ParticipantEntities& info, RosDistribution distribution);
/// Reads one sample of the given layout back (GIDs cut to their 16-byte GUID; the rest of a Gid must be 0).
/// Throws DecodeError naming the field for a sample of another layout or a truncated one.
[[nodiscard]] ParticipantEntities decodeParticipantEntities(std::span<const std::uint8_t> sample,
                                                            RosDistribution distribution);

}  // namespace densemap::ros2
