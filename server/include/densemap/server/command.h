// Commands that change or persist the map, as plain C++ types: what MapService::execute() takes. They
// arrive on their own admin topic (so a DDS-Security permissions file can grant queries without them)
// and every one that changes a layer goes through the pipeline's writer thread, in order with the scans.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "densemap/server/query.h"

namespace densemap::server {

/// Write the map to NAME.bt or NAME.ot in the server's map directory (a file name, never a path).
struct SaveCommand {
  std::string name;
};
/// Replace the map with NAME.bt / NAME.ot from the map directory (the dense layer starts over).
struct LoadCommand {
  std::string name;
};
/// Forget every cell inside a box (they become unknown).
struct ClearBoxCommand {
  Vec3f min = Vec3f::Zero(), max = Vec3f::Zero();
};
/// Forget the whole map, both layers.
struct ResetCommand {};

/// Write a snapshot of both layers to the data directory now (the journal behind it is then removed).
struct SnapshotCommand {};

/// Internal, never from the wire: bring the stored blocks of these key boxes back into memory for a query
/// that reached them (--window-query-load-s); the map's content does not change, so it is not journaled.
struct LoadStoredBlocksCommand {
  std::vector<std::pair<geometry::VoxelKey, geometry::VoxelKey>> boxes;
};

using Command = std::variant<SaveCommand, LoadCommand, ClearBoxCommand, ResetCommand, SnapshotCommand,
                             LoadStoredBlocksCommand>;

std::string_view commandName(const Command& c);

struct CommandResult {
  Status status = Status::kOk;
  std::string message;
  std::uint64_t map_version = 0;    ///< the map version after the command (for a save: the one written)
  std::uint64_t cells_changed = 0;  ///< cleared or reset: cells forgotten; load: cells loaded
  std::optional<MapSummary> map;    ///< save and load: the map written or read
};

}  // namespace densemap::server
