// The kinds of measurement the service takes (docs/formats.md §1), by file format: one
// registration record a format — its name (ingest/file_formats.h), what an upload of it may hold
// by default, and the handler of its kind that parses, analyses and turns a file into what is
// stored. A new format of a kind is one line of BuiltinFormats (server/measurements/kinds.cpp).
#pragma once

#include <string>
#include <vector>

#include "ingest/text_format.h"
#include "server/measurements/ingested.h"

namespace km::server {

// One format as the service knows it.
struct FormatRegistration {
  std::string format;         // e.g. "kinemetric-dbb/1"
  ingest::TextLimits limits;  // default upload limits (ServiceOptions::upload_limits)
  KindHandler handler;
};

// Every built-in format, one record each (tracker, DBB, straightness, flatness, parallelism,
// servo loads).
std::vector<FormatRegistration> BuiltinFormats();

}  // namespace km::server
