#pragma once
// A control request that cannot be served: the code for the Error reply and a message
// that names the bad field and value.
#include <stdexcept>
#include <string>
#include "hapticd/v1/hapticd.pb.h"

namespace hapticd::net {

class RequestError : public std::runtime_error {
 public:
  RequestError(v1::Error::Code code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  v1::Error::Code code() const { return code_; }

 private:
  v1::Error::Code code_;
};

inline RequestError BadRequest(const std::string& message) {
  return RequestError(v1::Error::CODE_BAD_REQUEST, message);
}

}  // namespace hapticd::net
