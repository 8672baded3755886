#include "densemap/server/map_store.h"

namespace densemap::server {

std::future<std::uint64_t> MapStore::post(std::function<std::uint64_t(map::OccupancyMap&)> command) {
  std::promise<std::uint64_t> promise;
  auto future = promise.get_future();
  {
    std::lock_guard lock(commands_mutex_);
    commands_.emplace_back(std::move(command), std::move(promise));
  }
  if (writer_gone_) runCommands();
  return future;
}

bool MapStore::hasCommands() const {
  std::lock_guard lock(commands_mutex_);
  return !commands_.empty();
}

bool MapStore::runCommands() {
  bool ran = false;
  for (;;) {
    std::pair<std::function<std::uint64_t(map::OccupancyMap&)>, std::promise<std::uint64_t>> item;
    {
      std::lock_guard lock(commands_mutex_);
      if (commands_.empty()) return ran;
      item = std::move(commands_.front());
      commands_.pop_front();
    }
    std::uint64_t changed = 0;
    try {
      write([&](map::OccupancyMap& m) { changed = item.first(m); });
      item.second.set_value(changed);
    } catch (...) {
      item.second.set_exception(std::current_exception());
    }
    ran = true;
  }
}

}  // namespace densemap::server
