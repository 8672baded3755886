#include "densemap/ros2/discovery_info.h"

#include <stdexcept>

#include "densemap/ros2/cdr.h"

namespace densemap::ros2 {

namespace {

/// rosidl's bound on node names and namespaces (string<256>).
constexpr std::size_t kMaxNameLength = 256;

void writeGid(CdrWriter& out, const Guid& guid, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; ++i) out.u8(i < guid.size() ? guid[i] : 0);
}

Guid readGid(CdrReader& in, std::size_t bytes, const char* field) {
  Guid guid{};
  for (std::size_t i = 0; i < bytes; ++i) {
    const std::uint8_t b = in.u8(field);
    if (i < guid.size()) {
      guid[i] = b;
    } else if (b != 0) {
      throw DecodeError(std::string(field) + ": a GID past its 16-byte GUID holds a non-zero byte");
    }
  }
  return guid;
}

std::string readName(CdrReader& in, const char* field) {
  std::string s = in.string(field);
  if (s.size() > kMaxNameLength) throw DecodeError(std::string(field) + " longer than 256 characters");
  return s;
}

std::vector<Guid> readGids(CdrReader& in, std::size_t bytes, const char* field) {
  const std::uint32_t n = in.sequenceLength(field, bytes);
  std::vector<Guid> gids;
  gids.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) gids.push_back(readGid(in, bytes, field));
  return gids;
}

}  // namespace

std::size_t gidBytes(RosDistribution distribution) {
  return distribution == RosDistribution::kHumble ? 24 : 16;
}

RosDistribution parseRosDistribution(const std::string& name) {
  if (name == "humble") return RosDistribution::kHumble;
  if (name == "jazzy") return RosDistribution::kJazzy;
  throw std::invalid_argument("ROS 2 distribution '" + name + "': humble (also Iron) or jazzy");
}

std::vector<std::uint8_t> encode(const ParticipantEntities& info, RosDistribution distribution) {
  const std::size_t bytes = gidBytes(distribution);
  CdrWriter out;
  writeGid(out, info.participant, bytes);
  out.u32(static_cast<std::uint32_t>(info.nodes.size()));
  for (const NodeEntities& node : info.nodes) {
    out.string(node.node_namespace);
    out.string(node.node_name);
    out.u32(static_cast<std::uint32_t>(node.readers.size()));
    for (const Guid& g : node.readers) writeGid(out, g, bytes);
    out.u32(static_cast<std::uint32_t>(node.writers.size()));
    for (const Guid& g : node.writers) writeGid(out, g, bytes);
  }
  return out.finish();
}

ParticipantEntities decodeParticipantEntities(std::span<const std::uint8_t> sample,
                                              RosDistribution distribution) {
  const std::size_t bytes = gidBytes(distribution);
  CdrReader in(sample);
  ParticipantEntities info;
  info.participant = readGid(in, bytes, "gid");
  // A node takes at least its two string lengths and two sequence lengths.
  const std::uint32_t nodes = in.sequenceLength("node_entities_info_seq", 16);
  for (std::uint32_t i = 0; i < nodes; ++i) {
    NodeEntities node;
    node.node_namespace = readName(in, "node_namespace");
    node.node_name = readName(in, "node_name");
    node.readers = readGids(in, bytes, "reader_gid_seq");
    node.writers = readGids(in, bytes, "writer_gid_seq");
    info.nodes.push_back(std::move(node));
  }
  in.expectEnd("ParticipantEntitiesInfo");
  return info;
}

}  // namespace densemap::ros2
