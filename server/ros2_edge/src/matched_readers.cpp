#include "densemap/server/ros2_edge/matched_readers.h"

#include <fastdds/rtps/common/InstanceHandle.h>
#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>

namespace densemap::server::ros2_edge {

void MatchedReaders::on_publication_matched(eprosima::fastdds::dds::DataWriter*,
                                            const eprosima::fastdds::dds::PublicationMatchedStatus& status) {
  const eprosima::fastrtps::rtps::GUID_t reader =
      eprosima::fastrtps::rtps::iHandle2GUID(status.last_subscription_handle);
  {
    std::lock_guard lock(mutex_);
    if (status.current_count_change > 0)
      readers_.insert(reader);
    else if (status.current_count_change < 0)
      readers_.erase(reader);
  }
  changed_.notify_all();
}

bool MatchedReaders::waitFor(const eprosima::fastrtps::rtps::GUID_t& reader,
                             std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return readers_.count(reader) > 0; });
}

bool MatchedReaders::matched(const eprosima::fastrtps::rtps::GUID_t& reader) const {
  std::lock_guard lock(mutex_);
  return readers_.count(reader) > 0;
}

}  // namespace densemap::server::ros2_edge
