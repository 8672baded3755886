#include "densemap/server/status.h"
#include "densemap/server/command.h"

namespace densemap::server {

std::string_view toString(Status s) {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kInvalidArgument:
      return "invalid argument";
    case Status::kUnknownKind:
      return "unknown kind";
    case Status::kLayerUnavailable:
      return "layer unavailable";
    case Status::kFailed:
      return "failed";
    case Status::kNotFound:
      return "not found";
    case Status::kUnavailable:
      return "unavailable";
    case Status::kBusy:
      return "busy";
  }
  return "unknown status";
}

std::string_view commandName(const Command& c) {
  static constexpr std::string_view kNames[] = {"save",  "load",     "clear box",
                                                "reset", "snapshot", "load stored blocks"};
  return kNames[c.index()];
}

}  // namespace densemap::server
