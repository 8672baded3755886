#include "densemap/server/durability/journal_record.h"

#include <cmath>

#include "densemap/util/byte_codec.h"

namespace densemap::server::durability {

namespace {
constexpr std::size_t kMaxRobotId = 4096;
}

std::string_view toString(RecordKind k) {
  switch (k) {
    case RecordKind::kScan:
      return "scan";
    case RecordKind::kClearBox:
      return "clear_box";
    case RecordKind::kReset:
      return "reset";
    case RecordKind::kLoad:
      return "load";
  }
  return "unknown";
}

bool changesMap(const Command& c) {
  return std::holds_alternative<ClearBoxCommand>(c) || std::holds_alternative<ResetCommand>(c) ||
         std::holds_alternative<LoadCommand>(c);
}

std::string encodeScanRecord(const ScanJob& job) {
  std::string out;
  const auto& pts = job.scan.points;
  out.reserve(256 + job.robot_id.size() + pts.size() * sizeof(geometry::Vec3f));
  util::ByteWriter w(out);
  w.string(job.robot_id);
  w.put(job.seq);
  w.put(job.publish_ns);
  w.put(job.received_ns);
  for (double v : job.position) w.put(v);
  for (double v : job.quaternion) w.put(v);
  // The pose the map used (validateScan built it from the two above): stored, not rebuilt, so a replay
  // needs no code of the door.
  const Eigen::Matrix<double, 3, 4> m = job.scan.pose.matrix().topRows<3>();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 3; ++r) w.put(m(r, c));
  w.put(static_cast<std::uint8_t>(job.scan.frame == io::PointFrame::kWorld ? 1 : 0));
  w.put(job.points_rejected);
  w.put(static_cast<std::uint64_t>(pts.size()));
  static_assert(sizeof(geometry::Vec3f) == 3 * sizeof(float));
  w.bytes(pts.data(), pts.size() * sizeof(geometry::Vec3f));
  return out;
}

ScanJob decodeScanRecord(std::string_view payload, std::size_t base) {
  util::ByteReader r(payload, base);
  ScanJob job;
  job.robot_id = r.string("robot id", kMaxRobotId);
  if (job.robot_id.empty()) r.fail("a scan record without a robot id");
  job.seq = r.get<std::uint64_t>("seq");
  job.publish_ns = r.get<std::int64_t>("publish_ns");
  job.received_ns = r.get<std::int64_t>("received_ns");
  for (double& v : job.position) v = r.get<double>("position");
  for (double& v : job.quaternion) v = r.get<double>("quaternion");
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 3; ++row) m(row, c) = r.get<double>("pose");
  if (!m.allFinite()) r.fail("a scan record with a non-finite pose");
  job.scan.pose.matrix() = m;
  const auto frame = r.get<std::uint8_t>("frame");
  if (frame > 1) r.fail("a scan record with frame " + std::to_string(frame));
  job.scan.frame = frame == 1 ? io::PointFrame::kWorld : io::PointFrame::kSensor;
  job.points_rejected = r.get<std::uint32_t>("points_rejected");
  const std::uint64_t n = r.count("point count", sizeof(geometry::Vec3f));
  job.scan.points.resize(n);
  std::memcpy(static_cast<void*>(job.scan.points.data()), r.take(n * sizeof(geometry::Vec3f), "points"),
              n * sizeof(geometry::Vec3f));
  if (!r.done()) r.fail("bytes after the scan record");
  return job;
}

RecordKind commandRecordKind(const Command& c) {
  if (std::holds_alternative<ClearBoxCommand>(c)) return RecordKind::kClearBox;
  if (std::holds_alternative<ResetCommand>(c)) return RecordKind::kReset;
  return RecordKind::kLoad;
}

std::string encodeCommandRecord(const Command& c, std::string_view loaded_file) {
  std::string out;
  util::ByteWriter w(out);
  if (const auto* b = std::get_if<ClearBoxCommand>(&c)) {
    for (int i = 0; i < 3; ++i) w.put(b->min[i]);
    for (int i = 0; i < 3; ++i) w.put(b->max[i]);
  } else if (const auto* l = std::get_if<LoadCommand>(&c)) {
    w.string(l->name);
    w.put(static_cast<std::uint64_t>(loaded_file.size()));
    w.bytes(loaded_file.data(), loaded_file.size());
  }
  return out;
}

DecodedCommand decodeCommandRecord(RecordKind kind, std::string_view payload, std::size_t base) {
  util::ByteReader r(payload, base);
  DecodedCommand d;
  switch (kind) {
    case RecordKind::kClearBox: {
      ClearBoxCommand b;
      for (int i = 0; i < 3; ++i) b.min[i] = r.get<float>("box min");
      for (int i = 0; i < 3; ++i) b.max[i] = r.get<float>("box max");
      if (!b.min.allFinite() || !b.max.allFinite()) r.fail("a clear-box record with a non-finite box");
      d.command = b;
      break;
    }
    case RecordKind::kReset:
      d.command = ResetCommand{};
      break;
    case RecordKind::kLoad: {
      LoadCommand l;
      l.name = r.string("map name", 4096);
      const std::uint64_t n = r.count("map file size", 1);
      d.loaded_file.assign(r.take(n, "map file"), n);
      d.command = l;
      break;
    }
    default:
      r.fail("record kind " + std::to_string(static_cast<std::uint32_t>(kind)) + " is not a command");
  }
  if (!r.done()) r.fail("bytes after the command record");
  return d;
}

}  // namespace densemap::server::durability
