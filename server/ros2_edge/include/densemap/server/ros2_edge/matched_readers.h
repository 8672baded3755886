#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>

#include <fastdds/rtps/common/Guid.h>
#include <fastdds/dds/publisher/DataWriterListener.hpp>

namespace densemap::server::ros2_edge {

/// The readers a writer has matched, by GUID, so a reply can wait for its client's reader.
///
/// Matching is not symmetric: an rmw_fastrtps client sends a request once its own writer and reader see
/// the service, which can be before the service's reply writer sees the client's reader. A reply written
/// then is lost (volatile durability). rmw_fastrtps's own services wait a bounded time for the client's
/// reader before they reply; so does the edge.
class MatchedReaders : public eprosima::fastdds::dds::DataWriterListener {
 public:
  void on_publication_matched(eprosima::fastdds::dds::DataWriter* writer,
                              const eprosima::fastdds::dds::PublicationMatchedStatus& status) override;

  /// True once `reader` is matched; false after `timeout` without it.
  bool waitFor(const eprosima::fastrtps::rtps::GUID_t& reader, std::chrono::milliseconds timeout);
  bool matched(const eprosima::fastrtps::rtps::GUID_t& reader) const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::set<eprosima::fastrtps::rtps::GUID_t> readers_;
};

}  // namespace densemap::server::ros2_edge
