// sensor_msgs/PointCloud2 as ROS 2 sends it: the CDR codec, every field layout densemap reads, and a
// clear, named refusal of every layout it cannot read.
#include <cmath>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/point_cloud_fields.h"

namespace densemap::ros2 {
namespace {

using geometry::Vec3f;

/// A cloud of `points` with x y z of `datatype` at `offsets` in points of `step` bytes, rows of `width`.
struct Layout {
  std::uint8_t datatype = PointField::kFloat32;
  std::array<std::uint32_t, 3> offsets{0, 4, 8};
  std::uint32_t step = 16;
  std::uint32_t width = 0;  // 0: all in one row
  std::uint32_t row_padding = 0;
};

PointCloud2 makeCloud(const std::vector<Vec3f>& points, const Layout& l, std::vector<std::uint8_t>& storage) {
  PointCloud2 c;
  c.header.frame_id = "velodyne";
  c.header.stamp = {1700000000, 5};
  c.width = l.width ? l.width : static_cast<std::uint32_t>(points.size());
  c.height = static_cast<std::uint32_t>(points.size() / c.width);
  const char* names[] = {"x", "y", "z"};
  // Other fields around the coordinates, as drivers send them (intensity, ring).
  c.fields.push_back({"intensity", l.step - 4, PointField::kFloat32, 1});
  for (int a = 0; a < 3; ++a) c.fields.push_back({names[a], l.offsets[a], l.datatype, 1});
  c.point_step = l.step;
  c.row_step = c.width * l.step + l.row_padding;
  storage.assign(std::size_t{c.row_step} * c.height, 0xAB);
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::uint8_t* p = storage.data() + (i / c.width) * c.row_step + (i % c.width) * l.step;
    for (int a = 0; a < 3; ++a) {
      if (l.datatype == PointField::kFloat64) {
        const double v = points[i][a];
        std::memcpy(p + l.offsets[a], &v, 8);
      } else {
        std::memcpy(p + l.offsets[a], &points[i][a], 4);
      }
    }
  }
  c.data = storage;
  c.is_dense = true;
  return c;
}

const std::vector<Vec3f> kPoints = {{1, 2, 3}, {-4.5f, 5.25f, 0}, {100, -200, 3.5f}, {0.125f, 0, -1}};

std::string errorOf(const PointCloud2& c) {
  try {
    cloudPoints(c);
  } catch (const DecodeError& e) {
    return e.what();
  }
  return "";
}

TEST(PointCloud2, RoundTripsThroughCdr) {
  std::vector<std::uint8_t> storage;
  const PointCloud2 c = makeCloud(kPoints, {}, storage);
  const std::vector<std::uint8_t> bytes = encode(c);
  ASSERT_EQ(bytes[0], 0x00);
  ASSERT_EQ(bytes[1], 0x01);  // CDR little endian, as rmw_fastrtps writes
  const PointCloud2 d = decodePointCloud2(bytes);
  EXPECT_EQ(d.header.frame_id, "velodyne");
  EXPECT_EQ(d.header.stamp.nanoseconds(), 1700000000000000005);
  EXPECT_EQ(d.fields.size(), 4u);
  EXPECT_EQ(d.point_step, 16u);
  ASSERT_EQ(d.data.size(), storage.size());
  EXPECT_EQ(0, std::memcmp(d.data.data(), storage.data(), storage.size()));
  EXPECT_EQ(cloudPoints(d).points, kPoints);
}

TEST(PointCloud2, ReadsFloat32AtAnyOffsetWithPadding) {
  std::vector<std::uint8_t> storage;
  Layout l;
  l.offsets = {8, 0, 20};  // z after y after x is not required
  l.step = 32;
  EXPECT_EQ(cloudPoints(makeCloud(kPoints, l, storage)).points, kPoints);
}

TEST(PointCloud2, ReadsFloat64) {
  std::vector<std::uint8_t> storage;
  Layout l;
  l.datatype = PointField::kFloat64;
  l.offsets = {0, 8, 16};
  l.step = 32;
  EXPECT_EQ(cloudPoints(makeCloud(kPoints, l, storage)).points, kPoints);
}

TEST(PointCloud2, ReadsOrganisedCloudsWithPaddedRows) {
  std::vector<std::uint8_t> storage;
  Layout l;
  l.width = 2;
  l.row_padding = 7;
  const PointCloud2 c = makeCloud(kPoints, l, storage);
  EXPECT_EQ(c.height, 2u);
  EXPECT_EQ(cloudPoints(c).points, kPoints);
}

TEST(PointCloud2, DropsAndCountsNaNPoints) {
  std::vector<Vec3f> points = kPoints;
  points[1].y() = std::numeric_limits<float>::quiet_NaN();
  points[3].z() = std::numeric_limits<float>::infinity();
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(points, {}, storage);
  c.is_dense = false;
  const CloudPoints out = cloudPoints(c);
  EXPECT_EQ(out.nonfinite_points, 2u);
  EXPECT_EQ(out.points, (std::vector<Vec3f>{kPoints[0], kPoints[2]}));
}

TEST(PointCloud2, Float64BeyondFloatRangeIsNotFinite) {
  std::vector<std::uint8_t> storage;
  Layout l;
  l.datatype = PointField::kFloat64;
  l.offsets = {0, 8, 16};
  l.step = 32;
  PointCloud2 c = makeCloud(kPoints, l, storage);
  const double huge = 1e300;
  std::memcpy(storage.data(), &huge, 8);
  EXPECT_EQ(cloudPoints(c).nonfinite_points, 1u);
}

TEST(PointCloud2, RefusesBigEndian) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.is_bigendian = true;
  EXPECT_NE(errorOf(c).find("big-endian"), std::string::npos);
}

TEST(PointCloud2, RefusesMissingCoordinate) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.fields.erase(c.fields.begin() + 3);  // z
  EXPECT_NE(errorOf(c).find("no field 'z' (fields: intensity x y)"), std::string::npos) << errorOf(c);
}

TEST(PointCloud2, RefusesIntegerCoordinates) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.fields[1].datatype = PointField::kInt32;
  EXPECT_NE(errorOf(c).find("datatype 5"), std::string::npos);
}

TEST(PointCloud2, RefusesFieldPastPointStep) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.fields[2].offset = 14;  // y, 4 bytes from 14 > point_step 16
  EXPECT_NE(errorOf(c).find("does not fit in point_step 16"), std::string::npos);
}

TEST(PointCloud2, RefusesDataShorterThanRowStepTimesHeight) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.data = c.data.first(c.data.size() - 1);
  EXPECT_NE(errorOf(c).find("row_step * height"), std::string::npos);
}

TEST(PointCloud2, RefusesInconsistentSteps) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.row_step = c.point_step * c.width - 1;
  EXPECT_NE(errorOf(c).find("below width * point_step"), std::string::npos);
  c = makeCloud(kPoints, {}, storage);
  c.point_step = 0;
  EXPECT_NE(errorOf(c).find("point_step 0"), std::string::npos);
  // A huge width must be refused from the sizes, not by reading past the data.
  c = makeCloud(kPoints, {}, storage);
  c.width = 0xFFFFFFFFu;
  c.row_step = 0xFFFFFFFFu;
  EXPECT_FALSE(errorOf(c).empty());
}

TEST(PointCloud2, AnEmptyCloudHasNoPointsWhateverItsHeight) {
  // Width 0 and a claimed height of 2^32 - 1 rows (found by fuzz_ros2_point_cloud: it walked every row).
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.width = 0;
  c.height = 0xFFFFFFFFu;
  c.row_step = 0;
  const CloudPoints p = cloudPoints(c);
  EXPECT_TRUE(p.points.empty());
  EXPECT_EQ(p.nonfinite_points, 0u);
}

TEST(PointCloud2, RefusesDuplicateCoordinateFields) {
  std::vector<std::uint8_t> storage;
  PointCloud2 c = makeCloud(kPoints, {}, storage);
  c.fields.push_back({"x", 12, PointField::kFloat32, 1});
  EXPECT_NE(errorOf(c).find("two fields named 'x'"), std::string::npos);
}

TEST(PointCloud2Cdr, EveryTruncationIsAnErrorNotACrash) {
  std::vector<std::uint8_t> storage;
  const std::vector<std::uint8_t> bytes = encode(makeCloud(kPoints, {}, storage));
  for (std::size_t n = 0; n + 1 < bytes.size(); ++n) {
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_THROW(decodePointCloud2(cut), DecodeError) << "cut at " << n;
  }
}

TEST(PointCloud2Cdr, HugeClaimedSequencesFailBeforeAllocating) {
  std::vector<std::uint8_t> storage;
  std::vector<std::uint8_t> bytes = encode(makeCloud(kPoints, {}, storage));
  // The fields count follows header (8 + 4 + "velodyne\0" = 21 -> aligned 24) + height + width.
  const std::uint32_t huge = 0x7FFFFFFF;
  std::memcpy(bytes.data() + 4 + 24 + 8, &huge, 4);
  try {
    decodePointCloud2(bytes);
    ADD_FAILURE() << "decoded";
  } catch (const DecodeError& e) {
    EXPECT_NE(std::string(e.what()).find("claims 2147483647 elements"), std::string::npos) << e.what();
  }
}

TEST(PointCloud2Cdr, RefusesOtherEncapsulations) {
  std::vector<std::uint8_t> storage;
  std::vector<std::uint8_t> bytes = encode(makeCloud(kPoints, {}, storage));
  bytes[1] = 0x07;  // XCDR2 parameter list
  EXPECT_THROW(decodePointCloud2(bytes), DecodeError);
}

TEST(PointCloud2Cdr, ReadsBigEndianCdr) {
  // A DDS writer may choose CDR big endian (encapsulation 0,0); the encoding of the sample, not of the
  // point data, which is_bigendian describes.
  CdrWriter le;
  le.u32(0x01020304);
  le.f64(2.5);
  std::vector<std::uint8_t> be = {0x00, 0x00, 0x00, 0x00, 0x01, 0x02, 0x03, 0x04, 0, 0, 0, 0};
  const double v = 2.5;
  std::uint8_t raw[8];
  std::memcpy(raw, &v, 8);
  for (int i = 7; i >= 0; --i) be.push_back(raw[i]);
  CdrReader in(be);
  EXPECT_EQ(in.u32("a"), 0x01020304u);
  EXPECT_EQ(in.f64("b"), 2.5);
}

}  // namespace
}  // namespace densemap::ros2
