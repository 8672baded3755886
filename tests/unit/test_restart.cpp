// Restart and damage at the service level: a service stopped without a final snapshot (what a crash leaves:
// the newest snapshot and the journal after it) comes back bit for bit as the offline map of every scan it
// acknowledged, the dense layer too; a resend is applied once; and each damage class is found, reported
// with the file and offset, and either cut off (a torn tail) or refused with what to do.
#include <sys/mount.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/io/scan_source.h"
#include "densemap/map/map_file.h"
#include "densemap/server/durability/journal_segment.h"
#include "densemap/server/map_service.h"
#include "densemap/sources/open_source.h"
#include "map_service_helpers.h"
#include "temp_dir.h"
#include "test_data.h"

namespace densemap::test {
namespace {

using namespace server;
namespace fs = std::filesystem;
namespace du = server::durability;

ServiceOptions durableOptions(const fs::path& dir, const std::string& backend = "grid") {
  ServiceOptions o;
  o.map.backend = backend;
  o.data_dir = (dir / "data").string();
  o.map_dir = (dir / "maps").string();
  o.update_nice = 0;
  o.durability.journal_sync_ms = 2;
  o.durability.snapshot_every_scans = 0;  // snapshots only where a test asks for them
  o.durability.snapshot_every_s = 0;
  o.durability.snapshot_on_exit = false;  // what a crash leaves behind
  return o;
}

/// Submits the scans as robot `robot` from `first` on and waits for every outcome.
Outcomes& run(MapService& s, const std::vector<io::Scan>& scans, Outcomes& out, std::uint64_t first = 0,
              const std::string& robot = "r0") {
  for (std::size_t i = 0; i < scans.size(); ++i)
    EXPECT_TRUE(s.submit(jobOf(scans[i], robot, first + i), out.callback()).accepted);
  EXPECT_TRUE(out.waitFor(scans.size()));
  return out;
}

std::string otBytes(const MapService& s) {
  return s.mapStore().read(
      [](const map::OccupancyMap& m, std::uint64_t) { return map::encodeMap(m, map::OctomapFormat::kFull); });
}

std::vector<fs::path> segments(const ServiceOptions& o) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(o.data_dir) / "journal"))
    if (e.path().extension() == ".dmj") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

/// Offsets of the records in a segment.
std::vector<std::uint64_t> recordOffsets(const fs::path& segment) {
  std::ifstream in(segment, std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), {}};
  std::vector<std::uint64_t> out;
  for (const auto& r : du::scanSegment(bytes, segment.string(), 1 << 30).records) out.push_back(r.offset);
  return out;
}

void flipByte(const fs::path& file, std::uint64_t offset) {
  std::fstream f(file, std::ios::binary | std::ios::in | std::ios::out);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.read(&c, 1);
  c = static_cast<char>(c ^ 0x04);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(&c, 1);
}

/// Maps the scans in a service that stops without a final snapshot: the newest segment and the offsets
/// of its records.
std::pair<fs::path, std::vector<std::uint64_t>> journalOnly(const ServiceOptions& o,
                                                            const std::vector<io::Scan>& scans) {
  {
    MapService a(o);
    Outcomes out;
    run(a, scans, out);
  }
  const fs::path seg = segments(o).back();
  return {seg, recordOffsets(seg)};
}

void expectRestartIsExact(const std::vector<io::Scan>& scans, const std::string& backend) {
  TempDir tmp;
  ServiceOptions o = durableOptions(tmp.path, backend);
  const std::size_t half = scans.size() / 2;
  {
    MapService a(o);
    Outcomes out;
    run(a, {scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(half)}, out);
    EXPECT_EQ(out.count(ScanOutcome::kInMap), half);
    ASSERT_EQ(a.execute(SnapshotCommand{}).status, Status::kOk);  // a snapshot in the middle
    Outcomes rest;
    run(a, {scans.begin() + static_cast<std::ptrdiff_t>(half), scans.end()}, rest, half);
    EXPECT_EQ(rest.count(ScanOutcome::kInMap), scans.size() - half);
    const auto s = a.statistics();
    EXPECT_EQ(s.durability.records, scans.size());
    EXPECT_EQ(s.durability.failures, 0u);
  }
  MapService b(o);
  ASSERT_TRUE(b.recovery());
  EXPECT_EQ(b.recovery()->snapshot_lsn, half);
  EXPECT_EQ(b.recovery()->records_replayed, scans.size() - half);
  EXPECT_TRUE(b.recovery()->damage.empty());
  map::MapOptions mo = o.map;
  const auto expected = offline(scans, mo);
  expectAnswers(b, *expected);
  // Octree: node for node (the .ot stream holds every inner node); grid: cell for cell.
  EXPECT_EQ(otBytes(b), map::encodeMap(*expected, map::OctomapFormat::kFull));
  EXPECT_EQ(b.lastDurableSeq("r0"), scans.size() - 1);
}

TEST(Restart, SnapshotPlusJournalIsTheOfflineMapGrid) { expectRestartIsExact(simScans(8), "grid"); }
TEST(Restart, SnapshotPlusJournalIsTheOfflineMapOctreeNodeForNode) {
  expectRestartIsExact(simScans(8), "octree");
}

TEST(Restart, Kitti00IsTheOfflineMapNodeForNode) {
  DENSEMAP_REQUIRE_DATA("kitti00");
  const auto src = sources::openSource(dataDir() + "/kitti00");
  std::vector<io::Scan> scans;
  for (std::size_t i = 0; i < 6; ++i) scans.push_back(src->read(i));
  expectRestartIsExact(scans, "octree");
}

// A server killed before its first periodic snapshot must not replay a growing journal at every restart:
// recovery that replayed at least snapshot_every_scans records snapshots before serving.
TEST(Restart, RecoveryOfManyRecordsSnapshotsBeforeServing) {
  TempDir tmp;
  ServiceOptions o = durableOptions(tmp.path);
  const auto scans = simScans(8);
  journalOnly(o, scans);  // 8 records, no snapshot (the periodic one is off here)
  o.durability.snapshot_every_scans = 5;
  std::string after_first;
  {
    MapService b(o);
    ASSERT_TRUE(b.recovery());
    EXPECT_FALSE(b.recovery()->snapshot_lsn.has_value());
    EXPECT_EQ(b.recovery()->records_replayed, scans.size());
    EXPECT_EQ(b.statistics().durability.snapshots, 1u);
    EXPECT_EQ(b.statistics().durability.snapshot_lsn, scans.size());
    after_first = otBytes(b);
  }
  MapService c(o);  // a second crash: nothing left to replay
  ASSERT_TRUE(c.recovery());
  EXPECT_EQ(c.recovery()->snapshot_lsn, scans.size());
  EXPECT_EQ(c.recovery()->records_replayed, 0u);
  EXPECT_EQ(segments(o).size(), 1u);  // the replayed segment went with the snapshot
  map::MapOptions mo = o.map;
  EXPECT_EQ(otBytes(c), map::encodeMap(*offline(scans, mo), map::OctomapFormat::kFull));
  EXPECT_EQ(otBytes(c), after_first);
  EXPECT_EQ(c.lastDurableSeq("r0"), scans.size() - 1);
}

/// Decay's clock is the scans' receive time (journaled) and the snapshot keeps it: the served map equals
/// the offline map decayed at the same times, before and after a restart from snapshot + journal, and a
/// restarted server goes on decaying as the uninterrupted run would.
TEST(Restart, WithDecayTheRestartedMapDecaysAsTheUninterruptedOne) {
  TempDir tmp;
  ServiceOptions o = durableOptions(tmp.path);
  o.map.decay = {1.0, 0.2};
  const std::vector<io::Scan> scans = simScans(14);
  const std::int64_t t0 = 1'800'000'000'000'000'000;
  // 0.1 s apart, with a 3 s pause before the last two (the map decays a lot in between).
  auto receivedNs = [&](std::size_t i) {
    return t0 + static_cast<std::int64_t>(i) * 100'000'000 + (i >= 12 ? 3'000'000'000 : 0);
  };
  auto submit = [&](MapService& s, std::size_t from, std::size_t to) {
    Outcomes out;
    for (std::size_t i = from; i < to; ++i) {
      ScanJob j = jobOf(scans[i], "r0", i);
      j.received_ns = receivedNs(i);
      EXPECT_TRUE(s.submit(std::move(j), out.callback()).accepted);
    }
    EXPECT_TRUE(out.waitFor(to - from));
    EXPECT_EQ(out.count(ScanOutcome::kInMap), to - from);
  };
  auto offlineUpTo = [&](std::size_t n) {
    auto m = map::makeMap(o.map);
    update::UpdateEngine engine;
    const auto noop = [](const std::function<void()>& commit) { commit(); };
    for (std::size_t i = 0; i < n; ++i) {
      io::Scan sent = scans[i];
      const ScanJob j = jobOf(scans[i], "x", 0);
      sent.pose = io::poseFromQuaternion(j.position, j.quaternion);
      m->advanceTime(static_cast<double>(receivedNs(i)) * 1e-9, noop);
      engine.insert(*m, sent.worldPoints(), sent.origin());
    }
    return m;
  };
  std::string served;
  {
    MapService a(o);
    submit(a, 0, 6);
    ASSERT_EQ(a.execute(SnapshotCommand{}).status, Status::kOk);
    submit(a, 6, 12);
    served = otBytes(a);
  }
  const auto expected = offlineUpTo(12);
  // Compared as booleans: a failure should not print two map files.
  EXPECT_TRUE(served == map::encodeMap(*expected, map::OctomapFormat::kFull)) << "served = offline, decayed";
  map::MapOptions no_decay = o.map;
  no_decay.decay = {};
  EXPECT_FALSE(served == map::encodeMap(*offline({scans.begin(), scans.begin() + 12}, no_decay),
                                        map::OctomapFormat::kFull))
      << "decay changed the map";
  MapService b(o);
  ASSERT_TRUE(b.recovery());
  EXPECT_EQ(b.recovery()->snapshot_lsn, 6u);
  EXPECT_TRUE(otBytes(b) == served) << "snapshot (with its map time) + journal replay";
  submit(b, 12, 14);
  EXPECT_TRUE(otBytes(b) == map::encodeMap(*offlineUpTo(14), map::OctomapFormat::kFull))
      << "after the restart the map decays as the uninterrupted run would";
}

TEST(Restart, ResendsAreAppliedOnceAcrossRestarts) {
  TempDir tmp;
  const auto scans = simScans(4);
  ServiceOptions o = durableOptions(tmp.path);
  {
    MapService a(o);
    Outcomes out;
    run(a, scans, out);
    Outcomes again;  // the same pairs while running
    run(a, {scans[1]}, again, 1);
    EXPECT_EQ(again.count(ScanOutcome::kDuplicate), 1u) << again.lastWhy();
  }
  MapService b(o);
  const std::string before = otBytes(b);
  const std::uint64_t version = b.mapStore().version();
  Outcomes resent;
  run(b, scans, resent);  // a robot that resends everything after the restart
  EXPECT_EQ(resent.count(ScanOutcome::kDuplicate), scans.size());
  EXPECT_EQ(b.mapStore().version(), version);
  EXPECT_EQ(otBytes(b), before);
  const auto stats = b.statistics();
  ASSERT_EQ(stats.robots.size(), 1u);
  const RobotCounters& r = stats.robots[0].second;
  EXPECT_EQ(r.durable_scans, scans.size());
  EXPECT_EQ(r.journaled_scans, scans.size()) << "a pair in the journal twice";
  EXPECT_EQ(r.duplicates, scans.size());
  EXPECT_EQ(r.last_durable_seq, scans.size() - 1);
  // A new sequence number still goes in.
  Outcomes fresh;
  run(b, {scans[0]}, fresh, 100);
  EXPECT_EQ(fresh.count(ScanOutcome::kInMap), 1u);
}

TEST(Restart, DenseLayerIsTheOfflineLayerOfEveryScan) {
  TempDir tmp;
  const auto scans = simScans(5);
  ServiceOptions o = durableOptions(tmp.path);
  o.dense.method = "akimap";
  o.dense_overflow = OverflowPolicy::kWait;  // every scan reaches the layer
  {
    MapService a(o);
    Outcomes out;
    run(a, {scans.begin(), scans.begin() + 2}, out);
    ASSERT_EQ(a.execute(SnapshotCommand{}).status, Status::kOk);
    Outcomes rest;
    run(a, {scans.begin() + 2, scans.end()}, rest, 2);
  }
  MapService b(o);
  auto layer = dense::makeDenseLayer(o.dense, o.map.resolution);
  for (const io::Scan& s : scans) {
    io::Scan sent = s;
    const ScanJob j = jobOf(s, "x", 0);
    sent.pose = io::poseFromQuaternion(j.position, j.quaternion);
    layer->insert(sent.worldPoints(), sent.origin());
  }
  ASSERT_NE(b.denseStore(), nullptr);
  const std::string served =
      b.denseStore()->read([](const dense::KernelLayer& l, std::uint64_t) { return l.saveState(); });
  EXPECT_EQ(served, layer->saveState()) << "the restarted dense layer differs from the offline one";
  expectAnswers(b, *offline(scans, o.map));
}

TEST(Restart, CommandsAreJournaledInOrderWithTheScans) {
  TempDir tmp;
  const auto scans = simScans(6);
  ServiceOptions o = durableOptions(tmp.path);
  std::string served;
  {
    MapService a(o);
    Outcomes out;
    run(a, {scans.begin(), scans.begin() + 2}, out);
    ASSERT_EQ(a.execute(SaveCommand{"two.ot"}).status, Status::kOk);
    ClearBoxCommand box{Vec3f(-3, -3, -1), Vec3f(3, 3, 2)};
    ASSERT_EQ(a.execute(box).status, Status::kOk);
    Outcomes more;
    run(a, {scans.begin() + 2, scans.begin() + 4}, more, 2);
    ASSERT_EQ(a.execute(ResetCommand{}).status, Status::kOk);
    ASSERT_EQ(a.execute(LoadCommand{"two.ot"}).status, Status::kOk);
    Outcomes last;
    run(a, {scans.begin() + 4, scans.end()}, last, 4);
    served = otBytes(a);
  }
  fs::remove(fs::path(o.map_dir) / "two.ot");  // the journal holds the loaded file itself
  MapService b(o);
  EXPECT_EQ(b.recovery()->records_replayed, 6u + 3u);
  EXPECT_EQ(otBytes(b), served);
}

TEST(RestartDamage, TornTailIsCutOffAndTheServiceContinues) {
  TempDir tmp;
  const auto scans = simScans(4);
  ServiceOptions o = durableOptions(tmp.path);
  const auto [seg, offsets] = journalOnly(o, scans);
  ASSERT_EQ(offsets.size(), 4u);
  fs::resize_file(seg, offsets[3] + 50);  // the last record's write, cut short
  MapService b(o);
  ASSERT_EQ(b.recovery()->damage.size(), 1u);
  const du::JournalDamage& d = b.recovery()->damage[0];
  EXPECT_TRUE(d.torn_tail);
  EXPECT_EQ(d.file, seg.string());
  EXPECT_EQ(d.offset, offsets[3]);
  expectAnswers(b, *offline({scans.begin(), scans.begin() + 3}, o.map));
  Outcomes resent;  // the robot resends the one it had no acknowledgement for
  run(b, {scans[3]}, resent, 3);
  EXPECT_EQ(resent.count(ScanOutcome::kInMap), 1u);
  expectAnswers(b, *offline(scans, o.map));
}

TEST(RestartDamage, FlippedBitInTheMiddleRefusesToStartThenCutKeepsThePrefix) {
  TempDir tmp;
  const auto scans = simScans(5);
  ServiceOptions o = durableOptions(tmp.path);
  const auto [seg, offsets] = journalOnly(o, scans);
  flipByte(seg, offsets[2] + du::kRecordHeaderBytes + 300);
  try {
    MapService b(o);
    FAIL() << "a damaged journal was accepted";
  } catch (const du::RecoveryError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(seg.string()), std::string::npos) << what;
    EXPECT_NE(what.find("offset " + std::to_string(offsets[2])), std::string::npos) << what;
    EXPECT_NE(what.find("--journal-recover cut"), std::string::npos) << what;
  }
  o.durability.journal_recover = "cut";
  MapService c(o);
  ASSERT_EQ(c.recovery()->damage.size(), 1u);
  EXPECT_FALSE(c.recovery()->damage[0].torn_tail);
  expectAnswers(c, *offline({scans.begin(), scans.begin() + 2}, o.map));
  EXPECT_TRUE(fs::exists(seg.string() + ".damaged"));
}

TEST(RestartDamage, TruncatedOrCorruptSnapshotRefusesToStart) {
  for (const bool truncate : {true, false}) {
    TempDir tmp;
    const auto scans = simScans(3);
    ServiceOptions o = durableOptions(tmp.path);
    {
      MapService a(o);
      Outcomes out;
      run(a, scans, out);
      ASSERT_EQ(a.execute(SnapshotCommand{}).status, Status::kOk);
    }
    const fs::path snap = fs::path(o.data_dir) / "snapshots" / du::snapshotFileName(3);
    ASSERT_TRUE(fs::exists(snap));
    if (truncate) {
      fs::resize_file(snap, fs::file_size(snap) / 2);
    } else {
      flipByte(snap, fs::file_size(snap) / 2);
    }
    try {
      MapService b(o);
      FAIL() << "a damaged snapshot was accepted";
    } catch (const du::RecoveryError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(snap.string()), std::string::npos) << what;
      EXPECT_NE(what.find("restore"), std::string::npos) << what;
      EXPECT_NE(what.find(truncate ? "truncated" : "checksum"), std::string::npos) << what;
    }
  }
}

TEST(RestartDamage, UnwritableOrBusyOrMismatchedDataDirectoryRefusesToStart) {
  TempDir tmp;
  ServiceOptions o = durableOptions(tmp.path);
  std::ofstream(tmp.path / "a-file") << "x";
  ServiceOptions under_file = o;
  under_file.data_dir = (tmp.path / "a-file" / "data").string();
  try {
    MapService s(under_file);
    FAIL() << "a data directory under a file was accepted";
  } catch (const du::RecoveryError& e) {
    EXPECT_NE(std::string(e.what()).find("--data-dir"), std::string::npos) << e.what();
  }
  {
    MapService a(o);
    try {
      MapService b(o);
      FAIL() << "two services on one data directory";
    } catch (const du::RecoveryError& e) {
      EXPECT_NE(std::string(e.what()).find("in use"), std::string::npos) << e.what();
    }
    Outcomes out;
    run(a, simScans(1), out);
  }
  ServiceOptions other = o;
  other.map.resolution = 0.4;
  try {
    MapService c(other);
    FAIL() << "a journal of another resolution was replayed";
  } catch (const du::RecoveryError& e) {
    EXPECT_NE(std::string(e.what()).find("other map settings"), std::string::npos) << e.what();
  }
  // A read-only file system (root ignores permission bits, so a mount is the honest test).
  const fs::path ro = tmp.path / "ro";
  fs::create_directories(ro);
  if (::mount("tmpfs", ro.c_str(), "tmpfs", MS_RDONLY, "size=1m") != 0) {
    GTEST_SKIP() << "cannot mount a read-only tmpfs here (not root?): the read-only case is not checked";
  }
  ServiceOptions readonly = o;
  readonly.data_dir = (ro / "data").string();
  try {
    MapService d(readonly);
    ADD_FAILURE() << "a read-only data directory was accepted";
  } catch (const du::RecoveryError& e) {
    EXPECT_NE(std::string(e.what()).find("Read-only"), std::string::npos) << e.what();
  }
  ::umount(ro.c_str());
}

TEST(RestartDamage, FullDiskRefusesScansWithoutAcknowledgingThem) {
  TempDir tmp;
  const fs::path small = tmp.path / "small";
  fs::create_directories(small);
  if (::mount("tmpfs", small.c_str(), "tmpfs", 0, "size=2m") != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs here (not root?): the full-disk case is not checked";
  }
  const auto scans = simScans(16);  // ~200 KB each: the disk fills on the way
  ServiceOptions o = durableOptions(tmp.path);
  o.data_dir = (small / "data").string();
  std::vector<io::Scan> durable;
  std::size_t refused = 0;
  {
    MapService a(o);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      Outcomes one;
      run(a, {scans[i]}, one, i);
      if (one.count(ScanOutcome::kInMap) == 1) {
        durable.push_back(scans[i]);
      } else {
        ++refused;
        EXPECT_NE(one.lastWhy().find("No space left"), std::string::npos) << one.lastWhy();
        EXPECT_NE(one.lastWhy().find("not durable"), std::string::npos) << one.lastWhy();
      }
    }
    EXPECT_GT(refused, 0u) << "the disk never filled";
    EXPECT_GT(durable.size(), 0u);
    const auto s = a.statistics();
    EXPECT_EQ(s.durability.failures, refused);
    EXPECT_FALSE(s.durability.failed) << "a full disk is not a failed fsync";
    // The map holds exactly the acknowledged scans.
    expectAnswers(a, *offline(durable, o.map));
  }
  {
    MapService b(o);  // every acknowledged scan is back
    expectAnswers(b, *offline(durable, o.map));
  }
  ::umount(small.c_str());
}

TEST(Restart, JournalOffKeepsNothing) {
  TempDir tmp;
  ServiceOptions o = durableOptions(tmp.path);
  o.durability.journal = false;
  MapService a(o);
  EXPECT_FALSE(a.recovery());
  EXPECT_FALSE(fs::exists(o.data_dir));
  EXPECT_EQ(a.execute(SnapshotCommand{}).status, Status::kInvalidArgument);
}

}  // namespace
}  // namespace densemap::test
