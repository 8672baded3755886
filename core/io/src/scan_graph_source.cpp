// Our own parser of OctoMap's .graph format: octomap::ScanGraph::readBinary trusts every count in the
// file, so a corrupt file can make it allocate without bound or read past the end. This one checks each
// count against the bytes that remain and names the file in its errors.
#include "densemap/io/scan_graph_source.h"

#include <cmath>
#include <cstring>

#include "densemap/io/text_parse.h"

namespace densemap::io {

namespace {

class Reader {
 public:
  Reader(const std::string& path, std::string_view bytes) : path_(path), bytes_(bytes) {}
  template <class T>
  T get(const char* what) {
    if (remaining() < sizeof(T)) fail(std::string("truncated while reading ") + what);
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  [[noreturn]] void fail(const std::string& msg) const {
    throw SourceError(path_ + ": corrupt scan graph at byte " + std::to_string(pos_) + ": " + msg);
  }
  Eigen::Vector3d vec3(const char* what) {
    if (get<std::int32_t>(what) != 3) fail(std::string("bad vector header in ") + what);
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = get<double>(what);
    return v;
  }

 private:
  const std::string& path_;
  std::string_view bytes_;
  std::size_t pos_ = 0;
};

}  // namespace

std::vector<Scan> parseScanGraph(std::string_view bytes, const std::string& name) {
  Reader r(name, bytes);
  std::vector<Scan> scans;
  const auto nodes = r.get<std::uint32_t>("node count");
  constexpr std::size_t kMinNodeBytes = 4 + 4 + 24 + 4 + 32 + 4;
  if (nodes > r.remaining() / kMinNodeBytes)
    r.fail("node count " + std::to_string(nodes) + " exceeds the file size");
  for (std::uint32_t n = 0; n < nodes; ++n) {
    const auto count = r.get<std::uint32_t>("point count");
    if (count > r.remaining() / 28) r.fail("point count " + std::to_string(count) + " exceeds the file size");
    Scan s;
    s.index = n;
    s.frame = PointFrame::kSensor;
    s.points.reserve(count);
    for (std::uint32_t i = 0; i < count; ++i) {
      const Eigen::Vector3f p = r.vec3("point").cast<float>();
      if (!p.allFinite())
        r.fail("node " + std::to_string(n) + " point " + std::to_string(i) + " is not finite");
      s.points.push_back(p);
    }
    const Eigen::Vector3d t = r.vec3("pose translation");
    if (r.get<std::int32_t>("pose rotation") != 4) r.fail("bad quaternion header");
    double q[4];
    for (double& v : q) v = r.get<double>("pose rotation");
    Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
    if (!t.allFinite() || !std::isfinite(quat.norm()) || std::abs(quat.norm() - 1.0) > 1e-3)
      r.fail("node " + std::to_string(n) +
             " has an invalid pose (translation not finite or quaternion not unit)");
    s.pose = Eigen::Isometry3d::Identity();
    s.pose.linear() = quat.normalized().toRotationMatrix();
    s.pose.translation() = t;
    r.get<std::uint32_t>("node id");
    scans.push_back(std::move(s));
  }
  // Edges (constraints between nodes) are not needed for mapping; the edge count is still checked.
  if (r.remaining() >= 4) {
    const auto edges = r.get<std::uint32_t>("edge count");
    if (edges > r.remaining() / 8) r.fail("edge count exceeds the file size");
  }
  if (scans.empty()) throw SourceError(name + ": scan graph holds no scans");
  return scans;
}

ScanGraphSource::ScanGraphSource(const std::string& path)
    : path_(path), scans_(parseScanGraph(readFileBytes(path, std::size_t{1} << 34, "scan graph"), path)) {}

std::string ScanGraphSource::describe() const {
  return "OctoMap scan graph " + path_ + " (" + std::to_string(scans_.size()) + " scans)";
}

}  // namespace densemap::io
