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

/// Runs f; a RequestError, or any other exception (as kFailed), becomes `out.status` and `out.message`
/// (an Answer or a CommandResult): the service's doors never throw.
template <class Result, class F>
void reportingErrors(Result& out, F&& f) {
  try {
    f();
  } catch (const RequestError& e) {
    out.status = e.status();
    out.message = e.what();
  } catch (const std::exception& e) {
    out.status = Status::kFailed;
    out.message = e.what();
  }
}

}  // namespace densemap::server
