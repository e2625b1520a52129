// The errors of the service that only a request can meet, beside the typed errors every layer
// raises (analysis/core/errors.h); api/http.cpp maps each to one HTTP status, in one place.
#pragma once

#include "analysis/core/errors.h"

namespace km::server {

// What the request asks cannot be done in the present state of the record it names (HTTP
// 409), e.g. saving the machine of a job that is not finished, revoking the last admin token,
// approving a revision of a report that is no longer current.
class Conflict : public Error {
 public:
  using Error::Error;
};

// The caller is not authenticated (no token, or an unknown, revoked or expired one): HTTP 401.
class Unauthorized : public Error {
 public:
  using Error::Error;
};

// The caller is authenticated but may not do this (its role, another token's job, a device
// beyond the configured network): HTTP 403.
class Forbidden : public Error {
 public:
  using Error::Error;
};

}  // namespace km::server
