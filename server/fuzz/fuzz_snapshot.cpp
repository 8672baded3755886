// libFuzzer target for a snapshot as densemap-server loads it at start-up: the file's framing and sections
// (decodeSnapshot, with the optional map time of decay and the map window's state: MapWindow::restoreState),
// the robots' progress (RobotProgress::decode) and the
// dense layer's state (KernelLayer::restoreState). Each must refuse damage with util::FormatError, and a
// refused restore must leave the layer as it was.
#include <cstdlib>
#include <string_view>

#include "densemap/dense/dense_layer_factory.h"
#include "densemap/map/grid_map.h"
#include "densemap/server/map_window.h"
#include "densemap/server/durability/robot_progress.h"
#include "densemap/server/durability/snapshot_file.h"
#include "densemap/util/byte_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace du = densemap::server::durability;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const du::SnapshotContents s = du::decodeSnapshot(bytes);
    // What decodes, encodes back to the same contents (the optional map time included).
    const du::SnapshotContents again = du::decodeSnapshot(du::encodeSnapshot(s));
    if (again.map != s.map || again.progress != s.progress || again.dense != s.dense ||
        again.map_time_s != s.map_time_s || again.lsn != s.lsn)
      std::abort();
  } catch (const densemap::util::FormatError&) {
  }
  try {
    const du::RobotProgress p = du::RobotProgress::decode(bytes);
    if (du::RobotProgress::decode(p.encode()) != p) std::abort();  // what decodes, encodes back the same
  } catch (const densemap::util::FormatError&) {
  }
  try {
    densemap::server::MapWindow window({20.0, 0.0, false}, nullptr);
    densemap::map::GridMap grid(0.2);
    window.restoreState(bytes, grid);  // a dropping window: a state naming stored blocks is refused
  } catch (const densemap::util::FormatError&) {
  } catch (const std::runtime_error&) {
  }
  static const auto layer = [] {
    densemap::dense::DenseLayerOptions o;
    o.method = "akimap";
    return densemap::dense::makeDenseLayer(o, 0.2);
  }();
  const std::string before = layer->saveState();
  try {
    layer->restoreState(bytes);
    if (layer->saveState().size() > size + 64) std::abort();
  } catch (const densemap::util::FormatError&) {
    if (layer->saveState() != before) std::abort();
  }
  layer->clear();
  return 0;
}
