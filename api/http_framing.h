// The framing and identity headers of a request, judged before anything else is done with it
// (RFC 9112 §6, §3.2; RFC 9110 §7.2, §11.6.2). A request whose body length two parties could
// read differently is refused and its connection closed, so that no byte of it can be taken as
// the start of another request (request smuggling):
//   - Transfer-Encoding whose final coding is not `chunked` (`gzip`, `identity`, `xchunked`,
//     `chunked, identity`): 400; any other coding beside `chunked` (`gzip, chunked`), or
//     `chunked` twice: 501 (this server decodes no other coding); Transfer-Encoding in an
//     HTTP/1.0 request, or together with Content-Length: 400;
//   - Content-Length given twice: 400;
//   - an HTTP/1.1 request without Host, or any request with two Host headers: 400;
//   - two Authorization headers: 400 (which one a party would use is not defined).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace km::api {

struct FramingRefusal {
  int status = 400;
  std::string detail;
};

// `headers`: every header of the request in order, names lower case, values as received
// (without the surrounding white space); `version`: 10 or 11. nullopt when the request may go on.
std::optional<FramingRefusal> CheckFraming(
    const std::vector<std::pair<std::string, std::string>>& headers, unsigned version);

// The token of an `Authorization` value whose scheme is Bearer in any letter case, followed by
// one or more spaces (RFC 9110 §11.1, §11.4); nullopt for any other value.
std::optional<std::string> BearerToken(const std::string& authorization);

}  // namespace km::api
