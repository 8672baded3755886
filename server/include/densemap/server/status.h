// How a query or a command ended, in the service's own terms (the edges map it to their wire codes).
#pragma once

#include <string_view>

namespace densemap::server {

enum class Status {
  kOk,
  kInvalidArgument,   ///< malformed request; the message says which field
  kUnknownKind,       ///< a query or command this server does not know
  kLayerUnavailable,  ///< the layer is not built by this server's pipeline
  kFailed,            ///< the server could not do it (e.g. a file it cannot write)
  kNotFound,          ///< a load names a map that is not in the map directory
  kUnavailable,       ///< the service is stopping
  kBusy,              ///< too many queries waiting; the caller should retry later
};

std::string_view toString(Status s);

}  // namespace densemap::server
