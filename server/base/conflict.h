// What the request asks cannot be done in the present state of the record it names (HTTP
// 409), e.g. saving the machine of a job that is not finished, or revoking the last admin token.
#pragma once

#include "analysis/core/errors.h"

namespace km::server {

class Conflict : public Error {
 public:
  using Error::Error;
};

}  // namespace km::server
