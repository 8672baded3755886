// A snapshot: both layers and the robots' progress as of one journal record, in one file
// DATA_DIR/snapshots/<LSN, 20 digits>.dms:
//
//   magic u64 | version u32 | lsn u64 | created_ns i64 | fingerprint | sections | footer
//   section = tag u32 | length u64 | CRC-32 u32 | bytes     (progress, map as .ot, dense layer state,
//                                                           then, with decay on only, the map time f64,
//                                                           then, with a map window only, its state)
//   footer  = length of everything before u64 | CRC-32 of it u32 | end magic u64
//
// The footer makes a truncated file detectable; each section's CRC says which part is damaged.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace densemap::server::durability {

struct SnapshotContents {
  std::uint64_t lsn = 0;  ///< every journal record up to this one is in the snapshot
  std::int64_t created_ns = 0;
  std::string fingerprint;
  std::string progress;  ///< RobotProgress::encode()
  std::string map;       ///< the exact map as an OctoMap .ot file (log-odds; octree: node for node)
  std::string dense;     ///< KernelLayer::saveState(), empty without a dense layer
  /// The map's time (decay's clock, OccupancyMap::mapTime) when decay is on: a restart then decays as the
  /// uninterrupted run would. An optional last section; snapshots without it read as before.
  std::optional<double> map_time_s;
  /// MapWindow::snapshotState() when the rolling window or memory cap is on (an optional last section):
  /// which map blocks are stored out of memory, and under which version.
  std::string window;
};

std::string encodeSnapshot(const SnapshotContents& s);
/// Throws util::FormatError naming the part that is damaged and its offset.
SnapshotContents decodeSnapshot(std::string_view bytes);

std::string snapshotFileName(std::uint64_t lsn);
std::optional<std::uint64_t> snapshotLsn(const std::string& file_name);

/// Writes `bytes` to `path` atomically: a temporary file, fsync, rename, fsync of the directory. Throws
/// StorageError (and leaves no temporary file behind).
void writeFileAtomically(const std::filesystem::path& path, std::string_view bytes);

}  // namespace densemap::server::durability
