// libFuzzer target for the journal as densemap-server reads it at start-up: a segment's framing
// (scanSegment: headers, checksums, LSNs, the search for valid records after damage), each record's payload
// (zstd or not) and its decoding into a scan or a command. Damage must be reported, never crash, and the
// valid prefix must lie inside the input. The same bytes as a file name in DATA_DIR/blocks
// (parseBlockFileName): only exact names parse, and a parsed name prints back the same.
#include <cstdlib>
#include <string_view>

#include "densemap/server/durability/block_store.h"
#include "densemap/server/durability/journal_record.h"
#include "densemap/server/durability/journal_segment.h"
#include "densemap/util/byte_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace du = densemap::server::durability;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (const auto name = du::parseBlockFileName(bytes);
      name && du::blockFileName(name->first, name->second) != bytes)
    std::abort();
  const du::SegmentScan s = du::scanSegment(bytes, "fuzz.dmj", 1 << 22);
  if (s.valid_bytes > size) std::abort();
  std::uint64_t expect = s.header.first_lsn;
  for (const du::RecordView& r : s.records) {
    if (r.lsn != expect++ || r.offset >= size) std::abort();
    try {
      const std::string payload = du::payloadOf(r, 1 << 22);
      if (r.kind == du::RecordKind::kScan) {
        (void)du::decodeScanRecord(payload);
      } else {
        (void)du::decodeCommandRecord(r.kind, payload);
      }
    } catch (const densemap::util::FormatError&) {
    }
  }
  return 0;
}
