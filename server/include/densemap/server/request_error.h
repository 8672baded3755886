// A request the service refuses, with the status it answers (thrown inside the service, caught at its
// door: MapService::answer() and execute() never throw).
#pragma once

#include <stdexcept>
#include <string>

#include "densemap/server/status.h"

namespace densemap::server {

class RequestError : public std::runtime_error {
 public:
  RequestError(Status status, const std::string& what) : std::runtime_error(what), status_(status) {}
  Status status() const { return status_; }

 private:
  Status status_;
};

}  // namespace densemap::server
