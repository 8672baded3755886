// The journal's and the snapshots' files on their own: what is written reads back exactly, and every kind
// of damage is found where it is (file and offset), telling a torn tail from damage in the middle.
#include <filesystem>
#include <fstream>

#include <limits>

#include <gtest/gtest.h>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/server/durability/journal_record.h"
#include "densemap/server/durability/journal_segment.h"
#include "densemap/server/durability/robot_progress.h"
#include "densemap/server/durability/snapshot_file.h"
#include "densemap/util/byte_codec.h"
#include "map_service_helpers.h"
#include "temp_dir.h"

namespace densemap::test {
namespace {

using namespace server::durability;
namespace fs = std::filesystem;
constexpr std::uint64_t kMaxPayload = 64 << 20;

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

server::ScanJob validatedJob(const io::Scan& s, const std::string& robot, std::uint64_t seq) {
  server::ScanJob j = jobOf(s, robot, seq);
  j.scan.pose = io::poseFromQuaternion(j.position, j.quaternion);
  j.publish_ns = 1000 + static_cast<std::int64_t>(seq);
  j.points_rejected = 3;
  return j;
}

TEST(RobotProgress, IntervalsMergeAndEachPairCountsOnce) {
  RobotProgress p;
  for (std::uint64_t s : {5, 7, 6, 1, 2, 9}) EXPECT_TRUE(p.record("a", s));
  EXPECT_FALSE(p.record("a", 6));  // a resend
  EXPECT_TRUE(p.contains("a", 7));
  EXPECT_FALSE(p.contains("a", 8));
  EXPECT_FALSE(p.contains("b", 1));
  EXPECT_EQ(p.lastSeq("a"), 9u);
  EXPECT_EQ(p.count("a"), 6u);
  EXPECT_EQ(p.records("a"), 7u);  // the resend is counted as a record: records - count = pairs twice
  EXPECT_TRUE(p.record("a", 8));  // joins [5,7] and [9,9]
  const RobotProgress back = RobotProgress::decode(p.encode());
  EXPECT_EQ(back, p);
  std::size_t robots = 0;
  back.forEachRobot([&](const std::string& id, std::uint64_t count, std::uint64_t, std::uint64_t last) {
    EXPECT_EQ(id, "a");
    EXPECT_EQ(count, 7u);
    EXPECT_EQ(last, 9u);
    ++robots;
  });
  EXPECT_EQ(robots, 1u);
}

TEST(RobotProgress, DamagedBytesAreRefused) {
  RobotProgress p;
  p.record("robot-1", 3);
  p.record("robot-1", 10);
  std::string bytes = p.encode();
  EXPECT_THROW(RobotProgress::decode(bytes.substr(0, bytes.size() - 1)), util::FormatError);
  bytes[bytes.size() - 9] ^= 0x01;  // the last interval's first no longer matches the count
  EXPECT_THROW(RobotProgress::decode(bytes), util::FormatError);
  std::string huge(8, '\xff');  // 2^64-1 robots claimed
  EXPECT_THROW(RobotProgress::decode(huge), util::FormatError);
}

TEST(JournalRecord, ScanAndCommandsRoundTrip) {
  const auto scans = simScans(1);
  const server::ScanJob job = validatedJob(scans[0], "robot-7", 42);
  const server::ScanJob back = decodeScanRecord(encodeScanRecord(job));
  EXPECT_EQ(back.robot_id, "robot-7");
  EXPECT_EQ(back.seq, 42u);
  EXPECT_EQ(back.publish_ns, job.publish_ns);
  EXPECT_EQ(back.points_rejected, 3u);
  EXPECT_TRUE(back.scan.pose.matrix() == job.scan.pose.matrix());
  ASSERT_EQ(back.scan.points.size(), job.scan.points.size());
  EXPECT_TRUE(std::equal(back.scan.points.begin(), back.scan.points.end(), job.scan.points.begin()));
  EXPECT_TRUE(back.scan.worldPoints() == job.scan.worldPoints());

  server::ClearBoxCommand box{geometry::Vec3f(-1, -2, -3), geometry::Vec3f(4, 5, 6)};
  const DecodedCommand d = decodeCommandRecord(RecordKind::kClearBox, encodeCommandRecord(box));
  EXPECT_EQ(std::get<server::ClearBoxCommand>(d.command).max, box.max);
  const DecodedCommand l =
      decodeCommandRecord(RecordKind::kLoad, encodeCommandRecord(server::LoadCommand{"m.ot"}, "BYTES"));
  EXPECT_EQ(std::get<server::LoadCommand>(l.command).name, "m.ot");
  EXPECT_EQ(l.loaded_file, "BYTES");
  // A record that claims more points than it holds is refused, not allocated.
  std::string bad = encodeScanRecord(job);
  bad.resize(bad.size() - 6);
  EXPECT_THROW(decodeScanRecord(bad), util::FormatError);
}

/// Three segments' worth of records written through the writer, read back.
struct WrittenJournal {
  fs::path dir;
  std::vector<std::uint64_t> offsets;  // of each record in the (only) segment
  fs::path segment;
};

WrittenJournal writeJournal(const fs::path& dir, int records, int zstd = 0) {
  const auto scans = simScans(records);
  JournalWriter w(dir, "fp", 1, std::nullopt, 0, zstd);
  WrittenJournal out{dir, {}, dir / segmentFileName(1)};
  for (int i = 0; i < records; ++i) {
    out.offsets.push_back(fs::file_size(out.segment));
    EXPECT_EQ(w.append(RecordKind::kScan,
                       encodeScanRecord(validatedJob(scans[static_cast<std::size_t>(i)], "r", i))),
              static_cast<std::uint64_t>(i + 1));
  }
  w.sync();
  return out;
}

TEST(JournalSegment, RecordsReadBackInOrderCompressedOrNot) {
  for (int zstd : {0, 3}) {
    TempDir tmp;
    const WrittenJournal j = writeJournal(tmp.path, 4, zstd);
    const std::string bytes = readFile(j.segment);
    const SegmentScan s = scanSegment(bytes, j.segment.string(), kMaxPayload);
    ASSERT_FALSE(s.damage) << s.damage->describe();
    EXPECT_EQ(s.header.fingerprint, "fp");
    ASSERT_EQ(s.records.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
      EXPECT_EQ(s.records[i].lsn, i + 1);
      EXPECT_EQ(decodeScanRecord(payloadOf(s.records[i], kMaxPayload)).seq, i);
      EXPECT_EQ(s.records[i].flags != 0, zstd > 0);
    }
  }
}

TEST(JournalSegment, TornTailIsFoundAndCutOffAndTheWriterContinuesAfterIt) {
  TempDir tmp;
  const WrittenJournal j = writeJournal(tmp.path, 3);
  const std::uint64_t cut = j.offsets[2] + 100;  // inside the third record
  fs::resize_file(j.segment, cut);
  const std::string bytes = readFile(j.segment);
  const SegmentScan s = scanSegment(bytes, j.segment.string(), kMaxPayload);
  ASSERT_TRUE(s.damage);
  EXPECT_TRUE(s.damage->torn_tail);
  EXPECT_EQ(s.damage->offset, j.offsets[2]);
  EXPECT_NE(s.damage->describe().find(j.segment.string()), std::string::npos);
  EXPECT_EQ(s.records.size(), 2u);
  EXPECT_EQ(s.valid_bytes, j.offsets[2]);
  {
    JournalWriter w(tmp.path, "fp", 3, j.segment, s.valid_bytes);
    EXPECT_EQ(w.append(RecordKind::kReset, ""), 3u);
    w.sync();
  }
  const std::string again = readFile(j.segment);
  const SegmentScan s2 = scanSegment(again, j.segment.string(), kMaxPayload);
  EXPECT_FALSE(s2.damage);
  ASSERT_EQ(s2.records.size(), 3u);
  EXPECT_EQ(s2.records[2].kind, RecordKind::kReset);
}

TEST(JournalSegment, FlippedBitInTheMiddleIsDamageNotATornTail) {
  TempDir tmp;
  const WrittenJournal j = writeJournal(tmp.path, 4);
  std::string bytes = readFile(j.segment);
  bytes[j.offsets[1] + kRecordHeaderBytes + 500] ^= 0x10;  // in the second record's points
  const SegmentScan s = scanSegment(bytes, j.segment.string(), kMaxPayload);
  ASSERT_TRUE(s.damage);
  EXPECT_FALSE(s.damage->torn_tail) << "valid records follow the damage";
  EXPECT_EQ(s.damage->offset, j.offsets[1]);
  EXPECT_NE(s.damage->what.find("checksum"), std::string::npos);
  EXPECT_EQ(s.records.size(), 1u);
  // The same flip in the last record, with nothing valid after it, reads as a torn tail.
  std::string last = readFile(j.segment);
  last[j.offsets[3] + kRecordHeaderBytes + 500] ^= 0x10;
  const SegmentScan t = scanSegment(last, j.segment.string(), kMaxPayload);
  ASSERT_TRUE(t.damage);
  EXPECT_TRUE(t.damage->torn_tail);
  EXPECT_EQ(t.records.size(), 3u);
  // A flipped bit in a header's length field, too.
  std::string header = readFile(j.segment);
  header[j.offsets[0] + 20] ^= 0x40;
  const SegmentScan h = scanSegment(header, j.segment.string(), kMaxPayload);
  ASSERT_TRUE(h.damage);
  EXPECT_FALSE(h.damage->torn_tail);
  EXPECT_EQ(h.damage->offset, j.offsets[0]);
}

TEST(JournalSegment, NotAJournalOrCutShortHeader) {
  const SegmentScan s = scanSegment("hello world, not a journal", "x.dmj", kMaxPayload);
  ASSERT_TRUE(s.damage);
  EXPECT_FALSE(s.damage->torn_tail);
  const SegmentScan e = scanSegment("", "y.dmj", kMaxPayload);
  ASSERT_TRUE(e.damage);
  EXPECT_TRUE(e.damage->torn_tail);  // created, never written: a crash at creation
  EXPECT_EQ(e.valid_bytes, 0u);
}

TEST(JournalSegment, SnapshotRemovesOnlyWholeSegmentsBehindIt) {
  TempDir tmp;
  JournalWriter w(tmp.path, "fp", 1);
  w.append(RecordKind::kReset, "");
  w.append(RecordKind::kReset, "");
  EXPECT_EQ(w.rotate(), 3u);
  w.append(RecordKind::kReset, "");
  EXPECT_EQ(w.dropThrough(1), 0u);  // segment 1 holds record 2 too
  EXPECT_EQ(w.dropThrough(2), 1u);
  EXPECT_FALSE(fs::exists(tmp.path / segmentFileName(1)));
  EXPECT_TRUE(fs::exists(tmp.path / segmentFileName(3)));
  EXPECT_EQ(w.dropThrough(3), 0u);  // the open segment always stays
}

TEST(SnapshotFile, RoundTripsAndTellsTruncationAndDamagedSections) {
  SnapshotContents s;
  s.lsn = 77;
  s.created_ns = 123;
  s.fingerprint = "backend=grid";
  s.progress = "progress-bytes";
  s.map = std::string(10000, 'm');
  s.dense = std::string(5000, 'd');
  const std::string bytes = encodeSnapshot(s);
  const SnapshotContents back = decodeSnapshot(bytes);
  EXPECT_EQ(back.lsn, 77u);
  EXPECT_EQ(back.map, s.map);
  EXPECT_EQ(back.dense, s.dense);
  EXPECT_EQ(back.progress, s.progress);
  try {
    decodeSnapshot(bytes.substr(0, bytes.size() / 2));
    FAIL() << "a truncated snapshot was read";
  } catch (const util::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x01;  // inside the map section
  try {
    decodeSnapshot(flipped);
    FAIL() << "a damaged snapshot was read";
  } catch (const util::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("map section"), std::string::npos) << e.what();
  }
  EXPECT_EQ(snapshotLsn(snapshotFileName(77)), 77u);
  EXPECT_FALSE(snapshotLsn("00000000000000000077.dms.tmp"));
}

TEST(SnapshotFile, TheMapTimeOfDecayIsAnOptionalLastSection) {
  SnapshotContents s;
  s.lsn = 5;
  s.map = "m";
  const std::string without = encodeSnapshot(s);
  EXPECT_FALSE(decodeSnapshot(without).map_time_s.has_value()) << "snapshots without decay read as before";
  s.map_time_s = 1.8e9 + 0.25;
  const std::string with = encodeSnapshot(s);
  EXPECT_EQ(with.size(), without.size() + 4 + 8 + 4 + 8);
  ASSERT_TRUE(decodeSnapshot(with).map_time_s.has_value());
  EXPECT_EQ(*decodeSnapshot(with).map_time_s, 1.8e9 + 0.25);
  s.map_time_s = std::numeric_limits<double>::infinity();
  try {
    decodeSnapshot(encodeSnapshot(s));
    FAIL() << "an infinite map time was read";
  } catch (const util::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("map time"), std::string::npos) << e.what();
  }
}

TEST(SnapshotFile, TheMapWindowIsAnOptionalLastSectionWithOrWithoutTheMapTime) {
  SnapshotContents s;
  s.lsn = 5;
  s.map = "m";
  s.window = "window-state";
  EXPECT_EQ(decodeSnapshot(encodeSnapshot(s)).window, "window-state");
  EXPECT_FALSE(decodeSnapshot(encodeSnapshot(s)).map_time_s.has_value());
  s.map_time_s = 3.0;
  const SnapshotContents both = decodeSnapshot(encodeSnapshot(s));
  EXPECT_EQ(both.window, "window-state");
  EXPECT_EQ(both.map_time_s, 3.0);
  s.window.clear();
  EXPECT_TRUE(decodeSnapshot(encodeSnapshot(s)).window.empty());
}

TEST(SnapshotFile, WrittenAtomically) {
  TempDir tmp;
  writeFileAtomically(tmp.path / "a.dms", "first");
  writeFileAtomically(tmp.path / "a.dms", "second");
  EXPECT_EQ(readFile(tmp.path / "a.dms"), "second");
  EXPECT_FALSE(fs::exists(tmp.path / "a.dms.tmp"));
  EXPECT_THROW(writeFileAtomically(tmp.path / "missing-dir" / "a.dms", "x"), StorageError);
}

TEST(DenseLayerState, ARestoredLayerContinuesBitForBit) {
  const auto scans = simScans(3);
  dense::DenseLayerOptions o;
  o.method = "akimap";
  auto a = dense::makeDenseLayer(o, 0.2);
  a->insert(scans[0].worldPoints(), scans[0].origin());
  auto b = dense::makeDenseLayer(o, 0.2);
  b->restoreState(a->saveState());
  EXPECT_EQ(b->saveState(), a->saveState());
  // Both go on from the same state (the free-sample generator included): same evidence everywhere.
  for (int i = 1; i < 3; ++i) {
    a->insert(scans[static_cast<std::size_t>(i)].worldPoints(), scans[static_cast<std::size_t>(i)].origin());
    b->insert(scans[static_cast<std::size_t>(i)].worldPoints(), scans[static_cast<std::size_t>(i)].origin());
  }
  EXPECT_EQ(b->saveState(), a->saveState());
  EXPECT_GT(a->blockCount(), 0u);
  // Another kind or resolution, or damaged bytes, are refused and leave the layer as it was.
  dense::DenseLayerOptions bgk = o;
  bgk.method = "bgk";
  auto c = dense::makeDenseLayer(bgk, 0.2);
  EXPECT_THROW(c->restoreState(a->saveState()), util::FormatError);
  auto d = dense::makeDenseLayer(o, 0.4);
  EXPECT_THROW(d->restoreState(a->saveState()), util::FormatError);
  const std::string state = a->saveState();
  EXPECT_THROW(b->restoreState(state.substr(0, state.size() - 10)), util::FormatError);
  EXPECT_EQ(b->saveState(), state);
}

}  // namespace
}  // namespace densemap::test
