// What one journal record holds: a scan as the occupancy stage takes it (validated, after densify, so a
// replay needs neither the network nor the model and is exact), or a command that changes a layer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "densemap/server/command.h"
#include "densemap/server/scan_job.h"

namespace densemap::server::durability {

enum class RecordKind : std::uint32_t { kScan = 1, kClearBox = 2, kReset = 3, kLoad = 4 };

std::string_view toString(RecordKind k);

/// Commands that change a layer are journaled; save and snapshot only read it.
bool changesMap(const Command& c);

std::string encodeScanRecord(const ScanJob& job);
/// Throws util::FormatError (offsets counted from `base`, where the payload starts in its file).
ScanJob decodeScanRecord(std::string_view payload, std::size_t base = 0);

/// A command record; a load carries the map file's bytes, so a replay does not depend on the map
/// directory as it is later.
std::string encodeCommandRecord(const Command& c, std::string_view loaded_file = {});
RecordKind commandRecordKind(const Command& c);
struct DecodedCommand {
  Command command;
  std::string loaded_file;  ///< kLoad: the map file's bytes
};
DecodedCommand decodeCommandRecord(RecordKind kind, std::string_view payload, std::size_t base = 0);

}  // namespace densemap::server::durability
