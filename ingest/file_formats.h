// The measurement file formats, one table line each (docs/architecture.md "Recipe: a new file
// format"): its name, the kind of measurement it holds, how it is recognised from its bytes and
// how its limits are checked before it is parsed. Each kind has one reader that recognises the
// format and reads it into the kind's type (ReadDbb for DBB tests), so every path that reads a
// file of that kind — the upload, the CLI, the stored re-analysis — reads every format of it.
//
// Recognition is a pure function of the bytes: stored bytes are always read again the same way
// as they were read at upload. No two formats recognise the same bytes (a unit test checks the
// examples of every format).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "analysis/dbb/dbb_types.h"
#include "ingest/text_format.h"

namespace km::ingest {

struct FileFormat {
  std::string_view name;  // as stored with a measurement (e.g. kinemetric-dbb/1, dbb-csv)
  std::string_view kind;  // the kind of measurement it holds (dbb, tracker, …)
  bool (*recognise)(std::string_view bytes);
  // The limits alone, in one pass that parses nothing; TooLarge naming file and line.
  void (*check_limits)(std::string_view bytes, const std::string& file, const TextLimits& limits);
};

// Every format, kinemetric formats first.
const std::vector<FileFormat>& FileFormats();

// The one format that recognises `bytes`; InvalidInput naming the file (line 1, field "format")
// and the known formats when none does. std::logic_error when two do (a programming error).
const FileFormat& RecogniseFormat(std::string_view bytes, const std::string& file);

// The names of the known formats, comma-separated (for messages).
std::string KnownFormats();

// A DBB test from a file of any DBB format (kinemetric-dbb/1, dbb-csv), with the default
// limits of ParseDbb; InvalidInput naming the file when it is not a DBB file.
dbb::DbbTest ReadDbb(std::string_view bytes, const std::string& file);

}  // namespace km::ingest
