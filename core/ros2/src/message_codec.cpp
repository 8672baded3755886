#include "densemap/ros2/message_codec.h"

namespace densemap::ros2 {

namespace {

// Smallest encoded sizes, so claimed sequence lengths are checked against what the sample holds.
constexpr std::size_t kMinPointFieldBytes = 4 + 1 + 4 + 1 + 4;  // empty name (length 1), offset, type, count
constexpr std::size_t kMinTransformBytes = 4 + 4 + 4 + 4 + 7 * 8;

Time readTime(CdrReader& in) {
  Time t;
  t.sec = in.i32("stamp.sec");
  t.nanosec = in.u32("stamp.nanosec");
  if (t.nanosec >= 1'000'000'000u)
    throw DecodeError("stamp.nanosec " + std::to_string(t.nanosec) + " is not below 1e9");
  return t;
}

Header readHeader(CdrReader& in) {
  Header h;
  h.stamp = readTime(in);
  h.frame_id = in.string("header.frame_id");
  return h;
}

Vector3 readVector3(CdrReader& in, const char* field) {
  return {in.f64(field), in.f64(field), in.f64(field)};
}

Quaternion readQuaternion(CdrReader& in, const char* field) {
  Quaternion q;
  q.x = in.f64(field);
  q.y = in.f64(field);
  q.z = in.f64(field);
  q.w = in.f64(field);
  return q;
}

void writeTime(CdrWriter& out, const Time& t) {
  out.i32(t.sec);
  out.u32(t.nanosec);
}
void writeHeader(CdrWriter& out, const Header& h) {
  writeTime(out, h.stamp);
  out.string(h.frame_id);
}
void writeVector3(CdrWriter& out, const Vector3& v) {
  for (double x : v) out.f64(x);
}
void writeQuaternion(CdrWriter& out, const Quaternion& q) {
  out.f64(q.x);
  out.f64(q.y);
  out.f64(q.z);
  out.f64(q.w);
}

std::vector<std::int8_t> readInt8Sequence(CdrReader& in, const char* field) {
  const auto bytes = in.byteSequence(field);
  return {reinterpret_cast<const std::int8_t*>(bytes.data()),
          reinterpret_cast<const std::int8_t*>(bytes.data() + bytes.size())};
}

void writeInt8Sequence(CdrWriter& out, const std::vector<std::int8_t>& data) {
  out.byteSequence({reinterpret_cast<const std::uint8_t*>(data.data()), data.size()});
}

}  // namespace

Time Time::fromNanoseconds(std::int64_t ns) {
  Time t;
  std::int64_t sec = ns / 1'000'000'000;
  std::int64_t rest = ns % 1'000'000'000;
  if (rest < 0) {
    rest += 1'000'000'000;
    --sec;
  }
  t.sec = static_cast<std::int32_t>(sec);
  t.nanosec = static_cast<std::uint32_t>(rest);
  return t;
}

PointCloud2 decodePointCloud2(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  PointCloud2 c;
  c.header = readHeader(in);
  c.height = in.u32("height");
  c.width = in.u32("width");
  const std::uint32_t n = in.sequenceLength("fields", kMinPointFieldBytes);
  c.fields.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    PointField f;
    f.name = in.string("fields[].name");
    f.offset = in.u32("fields[].offset");
    f.datatype = in.u8("fields[].datatype");
    f.count = in.u32("fields[].count");
    c.fields.push_back(std::move(f));
  }
  c.is_bigendian = in.boolean("is_bigendian");
  c.point_step = in.u32("point_step");
  c.row_step = in.u32("row_step");
  c.data = in.byteSequence("data");
  c.is_dense = in.boolean("is_dense");
  return c;
}

std::vector<std::uint8_t> encode(const PointCloud2& c) {
  CdrWriter out;
  writeHeader(out, c.header);
  out.u32(c.height);
  out.u32(c.width);
  out.u32(static_cast<std::uint32_t>(c.fields.size()));
  for (const PointField& f : c.fields) {
    out.string(f.name);
    out.u32(f.offset);
    out.u8(f.datatype);
    out.u32(f.count);
  }
  out.boolean(c.is_bigendian);
  out.u32(c.point_step);
  out.u32(c.row_step);
  out.byteSequence(c.data);
  out.boolean(c.is_dense);
  return out.finish();
}

TfMessage decodeTfMessage(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  TfMessage m;
  const std::uint32_t n = in.sequenceLength("transforms", kMinTransformBytes);
  m.transforms.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    TransformStamped t;
    t.header = readHeader(in);
    t.child_frame_id = in.string("child_frame_id");
    t.translation = readVector3(in, "transform.translation");
    t.rotation = readQuaternion(in, "transform.rotation");
    m.transforms.push_back(std::move(t));
  }
  return m;
}

std::vector<std::uint8_t> encode(const TfMessage& m) {
  CdrWriter out;
  out.u32(static_cast<std::uint32_t>(m.transforms.size()));
  for (const TransformStamped& t : m.transforms) {
    writeHeader(out, t.header);
    out.string(t.child_frame_id);
    writeVector3(out, t.translation);
    writeQuaternion(out, t.rotation);
  }
  return out.finish();
}

PoseStamped decodePoseStamped(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  PoseStamped p;
  p.header = readHeader(in);
  p.position = readVector3(in, "pose.position");
  p.orientation = readQuaternion(in, "pose.orientation");
  return p;
}

std::vector<std::uint8_t> encodePoseStamped(const PoseStamped& p) {
  CdrWriter out;
  writeHeader(out, p.header);
  writeVector3(out, p.position);
  writeQuaternion(out, p.orientation);
  return out.finish();
}

PoseStamped decodeOdometry(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  PoseStamped p;
  p.header = readHeader(in);
  p.child_frame_id = in.string("child_frame_id");
  p.position = readVector3(in, "pose.pose.position");
  p.orientation = readQuaternion(in, "pose.pose.orientation");
  for (int i = 0; i < 36; ++i) in.f64("pose.covariance");
  for (int i = 0; i < 6 + 36; ++i) in.f64("twist");
  return p;
}

std::vector<std::uint8_t> encodeOdometry(const PoseStamped& p) {
  CdrWriter out;
  writeHeader(out, p.header);
  out.string(p.child_frame_id);
  writeVector3(out, p.position);
  writeQuaternion(out, p.orientation);
  for (int i = 0; i < 36 + 6 + 36; ++i) out.f64(0.0);
  return out.finish();
}

OccupancyGrid decodeOccupancyGrid(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  OccupancyGrid g;
  g.header = readHeader(in);
  g.map_load_time = readTime(in);
  g.resolution = in.f32("info.resolution");
  g.width = in.u32("info.width");
  g.height = in.u32("info.height");
  g.origin_position = readVector3(in, "info.origin.position");
  g.origin_orientation = readQuaternion(in, "info.origin.orientation");
  g.data = readInt8Sequence(in, "data");
  return g;
}

std::vector<std::uint8_t> encode(const OccupancyGrid& g) {
  CdrWriter out;
  writeHeader(out, g.header);
  writeTime(out, g.map_load_time);
  out.f32(g.resolution);
  out.u32(g.width);
  out.u32(g.height);
  writeVector3(out, g.origin_position);
  writeQuaternion(out, g.origin_orientation);
  writeInt8Sequence(out, g.data);
  return out.finish();
}

Octomap decodeOctomap(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  Octomap m;
  m.header = readHeader(in);
  m.binary = in.boolean("binary");
  m.id = in.string("id");
  m.resolution = in.f64("resolution");
  m.data = readInt8Sequence(in, "data");
  return m;
}

std::vector<std::uint8_t> encode(const Octomap& m) {
  CdrWriter out;
  writeHeader(out, m.header);
  out.boolean(m.binary);
  out.string(m.id);
  out.f64(m.resolution);
  writeInt8Sequence(out, m.data);
  return out.finish();
}

BoundingBox decodeBoundingBoxRequest(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  BoundingBox b;
  b.min = readVector3(in, "min");
  b.max = readVector3(in, "max");
  in.expectEnd("BoundingBoxQuery request");
  return b;
}

std::vector<std::uint8_t> encodeBoundingBoxRequest(const BoundingBox& b) {
  CdrWriter out;
  writeVector3(out, b.min);
  writeVector3(out, b.max);
  return out.finish();
}

void decodeEmpty(std::span<const std::uint8_t> sample) {
  CdrReader in(sample);
  in.u8("structure_needs_at_least_one_member");
  in.expectEnd("empty request");
}

std::vector<std::uint8_t> encodeEmpty() {
  CdrWriter out;
  out.u8(0);
  return out.finish();
}

}  // namespace densemap::ros2
