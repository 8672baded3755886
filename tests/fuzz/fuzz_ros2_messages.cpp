// libFuzzer target for the other ROS 2 inputs (core/src/ros2): service requests the edge takes from the
// network (BoundingBoxQuery, Empty), the map messages it writes read back (Octomap, OccupancyGrid), a
// bag's recorded QoS and its metadata.yaml. The first byte chooses; each decodes or is refused with its
// error type, never anything else.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "densemap/ros2/bag_reader.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/qos.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using namespace densemap::ros2;
  const std::span<const std::uint8_t> sample(data + 1, size - 1);
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    switch (data[0] % 6) {
      case 0:
        decodeBoundingBoxRequest(sample);
        break;
      case 1:
        decodeEmpty(sample);
        break;
      case 2: {
        const Octomap m = decodeOctomap(sample);
        if (m.data.size() > sample.size()) std::abort();
        break;
      }
      case 3: {
        const OccupancyGrid g = decodeOccupancyGrid(sample);
        if (g.data.size() > sample.size()) std::abort();
        break;
      }
      case 4:
        if (const auto q = parseOfferedQos(text); q && q->depth == 0) std::abort();
        break;
      default: {
        const BagMetadata m = parseBagMetadata(text, "metadata.yaml");
        for (const auto& f : m.files)
          if (f.empty() || f.front() == '/' || f.rfind("..", 0) == 0) std::abort();
        break;
      }
    }
  } catch (const DecodeError&) {
  } catch (const BagError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
