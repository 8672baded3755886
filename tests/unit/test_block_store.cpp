// The store of map blocks out of memory (the rolling window, durability/block_store.h): files
// written once under a version, read back only as regular files within a size limit, collected when no
// index names them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "densemap/server/durability/block_store.h"
#include "densemap/server/durability/journal_segment.h"
#include "temp_dir.h"

namespace densemap::test {
namespace {

namespace du = server::durability;
namespace fs = std::filesystem;

TEST(BlockFileName, OnlyExactNamesParse) {
  EXPECT_EQ(du::blockFileName(0x2a, 7), "000000000000002a-00000000000000000007.dmb");
  const auto p = du::parseBlockFileName(du::blockFileName(0xfedcba9876543210ull, 18446744073709551615ull));
  ASSERT_TRUE(p);
  EXPECT_EQ(p->first, 0xfedcba9876543210ull);
  EXPECT_EQ(p->second, 18446744073709551615ull);
  for (const char* bad :
       {"", ".dmb", "000000000000002a-00000000000000000007.dmb.tmp",
        "000000000000002A-00000000000000000007.dmb", "000000000000002a_00000000000000000007.dmb",
        "00000000000002a-000000000000000000007.dmb", "000000000000002a-99999999999999999999.dmb",
        "../../000000000000002a-00000000000000000007.dmb", "000000000000002a-0000000000000000000x.dmb"})
    EXPECT_FALSE(du::parseBlockFileName(bad)) << bad;
}

TEST(BlockStore, PutGetSyncAndCollect) {
  TempDir tmp;
  du::BlockStore store(tmp.path / "blocks");
  store.put(1, 1, "one");
  store.put(1, 2, "one, later");
  store.put(2, 3, std::string(5000, 'b'));
  store.sync();
  EXPECT_EQ(store.get(1, 1), "one");
  EXPECT_EQ(store.get(1, 2), "one, later");
  EXPECT_EQ(store.get(2, 3).size(), 5000u);
  std::ofstream(tmp.path / "blocks" / "leftover.dmb.tmp") << "x";
  std::ofstream(tmp.path / "blocks" / "README") << "not ours";
  // Keep the newest version of each block only.
  EXPECT_EQ(store.collect([](std::uint64_t id, std::uint64_t v) { return !(id == 1 && v == 1); }), 2u);
  EXPECT_THROW(store.get(1, 1), du::StorageError);
  EXPECT_EQ(store.get(1, 2), "one, later");
  EXPECT_TRUE(fs::exists(tmp.path / "blocks" / "README")) << "names that are not ours are left alone";
  EXPECT_EQ(store.bytesOnDisk(), 10u + 5000u);
}

TEST(BlockStore, MissingLinkedOrHugeFilesAreRefusedWithTheirName) {
  TempDir tmp;
  du::BlockStore store(tmp.path / "blocks", 100);
  try {
    store.get(5, 9);
    FAIL() << "a missing block was read";
  } catch (const du::StorageError& e) {
    EXPECT_NE(std::string(e.what()).find(du::blockFileName(5, 9)), std::string::npos) << e.what();
  }
  std::ofstream(tmp.path / "secret") << "not a block";
  fs::create_symlink(tmp.path / "secret", tmp.path / "blocks" / du::blockFileName(6, 1));
  EXPECT_THROW(store.get(6, 1), du::StorageError) << "a symbolic link is never followed";
  store.put(7, 1, std::string(101, 'x'));
  try {
    store.get(7, 1);
    FAIL() << "a block over the limit was read";
  } catch (const du::StorageError& e) {
    EXPECT_NE(std::string(e.what()).find("more than a block can have"), std::string::npos) << e.what();
  }
  EXPECT_THROW(du::BlockStore(tmp.path / "secret" / "blocks"), du::StorageError) << "under a file";
}

TEST(BlockStore, FilesHandedOverAreSyncedOnAnotherThreadWhilePutsGoOn) {
  // The map window's snapshots: the writer thread takes the names, the snapshot's thread syncs them.
  TempDir tmp;
  du::BlockStore store(tmp.path / "blocks");
  for (std::uint64_t id = 1; id <= 200; ++id) store.put(id, id, std::string(100, 'a'));
  std::vector<std::string> handed = store.takeUnsynced();
  ASSERT_EQ(handed.size(), 200u);
  EXPECT_TRUE(store.takeUnsynced().empty()) << "taken once";
  store.collect([](std::uint64_t id, std::uint64_t) { return id != 7; });  // one collected before its sync
  std::thread syncer([&] { store.syncFiles(handed); });
  for (std::uint64_t id = 201; id <= 400; ++id) store.put(id, id, std::string(100, 'b'));
  syncer.join();
  EXPECT_TRUE(handed.empty()) << "a collected file is skipped, every other one synced";
  EXPECT_EQ(store.takeUnsynced().size(), 200u) << "the puts during the sync wait for the next one";
  EXPECT_EQ(store.get(200, 200), std::string(100, 'a'));
}

TEST(BlockStore, AFailedSyncKeepsTheNamesItDidNotSync) {
  TempDir tmp;
  du::BlockStore store(tmp.path / "blocks");
  store.put(1, 1, "one");
  store.put(3, 1, "three");
  std::ofstream(tmp.path / "secret") << "x";
  fs::create_symlink(tmp.path / "secret", tmp.path / "blocks" / du::blockFileName(2, 1));
  std::vector<std::string> names = {du::blockFileName(1, 1), du::blockFileName(2, 1),
                                    du::blockFileName(3, 1)};
  try {
    store.syncFiles(names);
    FAIL() << "a symbolic link was synced";
  } catch (const du::StorageError& e) {
    EXPECT_NE(std::string(e.what()).find(du::blockFileName(2, 1)), std::string::npos) << e.what();
  }
  EXPECT_EQ(names, (std::vector<std::string>{du::blockFileName(2, 1), du::blockFileName(3, 1)}));
}

}  // namespace
}  // namespace densemap::test
