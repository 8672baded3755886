// libFuzzer target for the other ROS 2 inputs (core/ros2/src): service requests the edge takes from the
// network (BoundingBoxQuery, Empty; in rmw_fastrtps' and rmw_cyclonedds' framing), the map messages it
// writes read back (Octomap, OccupancyGrid), ros_discovery_info samples (Humble and Jazzy GIDs), a bag's
// recorded QoS and its metadata.yaml. The first byte chooses; each decodes or is refused with its
// error type, never anything else.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "densemap/ros2/bag_reader.h"
#include "densemap/ros2/discovery_info.h"
#include "densemap/ros2/message_codec.h"
#include "densemap/ros2/qos.h"
#include "densemap/ros2/service_framing.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using namespace densemap::ros2;
  const std::span<const std::uint8_t> sample(data + 1, size - 1);
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    switch (data[0] % 9) {
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
      case 5: {
        // A request in rmw_cyclonedds' framing: the header comes off, the rest is one request or refused.
        const FramedRequest r = unframeRequest(sample, ServiceFraming::kRequestHeader);
        if (r.message.size() + kRequestHeaderBytes != sample.size()) std::abort();
        decodeBoundingBoxRequest(r.message);
        const auto reply = frameReply(r, encodeEmpty());
        if (reply.size() != encodeEmpty().size() + kRequestHeaderBytes) std::abort();
        break;
      }
      case 6:
      case 7: {
        const RosDistribution d = data[0] % 9 == 6 ? RosDistribution::kHumble : RosDistribution::kJazzy;
        const ParticipantEntities info = decodeParticipantEntities(sample, d);
        if (encode(info, d).size() > sample.size()) std::abort();  // it read every byte it wrote back
        break;
      }
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
