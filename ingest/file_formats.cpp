#include "ingest/file_formats.h"

#include <stdexcept>

#include "analysis/core/errors.h"
#include "ingest/dbb_csv_parser.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/positioning_parser.h"
#include "ingest/rotary/rotary_parser.h"
#include "ingest/servo_parser.h"
#include "ingest/tracker_parser.h"

namespace km::ingest {
namespace {

// The first non-blank line, trimmed, after an optional UTF-8 byte-order mark.
std::string_view FirstLine(std::string_view bytes) {
  if (bytes.substr(0, 3) == "\xEF\xBB\xBF") bytes.remove_prefix(3);
  const auto start = bytes.find_first_not_of(" \t\r\n\f\v");
  if (start == std::string_view::npos) return {};
  bytes.remove_prefix(start);
  return Trim(bytes.substr(0, bytes.find('\n')));
}

// A kinemetric format: the first non-blank line is `# format: NAME` (the spacing of
// `# key: value` lines free, as PeekFormat reads it).
bool FormatLineIs(std::string_view bytes, std::string_view name) {
  auto line = FirstLine(bytes);
  if (line.empty() || line.front() != '#') return false;
  line = Trim(line.substr(1));
  if (line.substr(0, 6) != "format") return false;
  line = Trim(line.substr(6));
  return !line.empty() && line.front() == ':' && Trim(line.substr(1)) == name;
}

template <typename Name>
constexpr FileFormat Kinemetric(Name name, std::string_view kind,
                                bool (*recognise)(std::string_view)) {
  return {std::string_view(name), kind, recognise, CheckTextLimits};
}

}  // namespace

const std::vector<FileFormat>& FileFormats() {
  // Captureless lambdas: one recogniser per kinemetric format, each its own `# format:` line.
  static const std::vector<FileFormat> formats = {
      Kinemetric(kDbbFormat, "dbb", [](std::string_view b) { return FormatLineIs(b, kDbbFormat); }),
      Kinemetric(kTrackerFormat, "tracker",
                 [](std::string_view b) { return FormatLineIs(b, kTrackerFormat); }),
      Kinemetric(kStraightnessFormat, "straightness",
                 [](std::string_view b) { return FormatLineIs(b, kStraightnessFormat); }),
      Kinemetric(kFlatnessFormat, "flatness",
                 [](std::string_view b) { return FormatLineIs(b, kFlatnessFormat); }),
      Kinemetric(kParallelismFormat, "parallelism",
                 [](std::string_view b) { return FormatLineIs(b, kParallelismFormat); }),
      Kinemetric(kServoFormat, "servo",
                 [](std::string_view b) { return FormatLineIs(b, kServoFormat); }),
      Kinemetric(kPositioningFormat, "positioning",
                 [](std::string_view b) { return FormatLineIs(b, kPositioningFormat); }),
      Kinemetric(kRotaryFormat, "rotary",
                 [](std::string_view b) { return FormatLineIs(b, kRotaryFormat); }),
      {kDbbCsvFormat, "dbb", IsDbbCsv, CheckDbbCsvLimits},
  };
  return formats;
}

std::string KnownFormats() {
  std::string out;
  for (const auto& f : FileFormats()) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

const FileFormat& RecogniseFormat(std::string_view bytes, const std::string& file) {
  const FileFormat* found = nullptr;
  for (const auto& f : FileFormats()) {
    if (!f.recognise(bytes)) continue;
    if (found) {
      throw std::logic_error("the formats " + std::string(found->name) + " and " +
                             std::string(f.name) + " both recognise " + file);
    }
    found = &f;
  }
  if (found) return *found;
  std::string named;
  try {
    named = PeekFormat(bytes, file);
  } catch (const InvalidInput& e) {
    // No format line. The message quotes nothing of the file: it stays short and plain whatever
    // the bytes are.
    throw InvalidInput(file, e.line(), "format",
                       "the format is not recognised: the first line must be '# format: "
                       "NAME/VERSION' (or 'machine_id,…' for dbb-csv); the known formats: " +
                           KnownFormats());
  }
  throw InvalidInput(file, 1, "format",
                     "unknown format '" + named + "'; the known formats: " + KnownFormats());
}

dbb::DbbTest ReadDbb(std::string_view bytes, const std::string& file) {
  const FileFormat& format = RecogniseFormat(bytes, file);
  if (format.name == kDbbFormat) return ParseDbb(bytes, file);
  if (format.name == kDbbCsvFormat) return ParseDbbCsv(bytes, file);
  throw InvalidInput(file, 1, "format",
                     "a " + std::string(format.name) + " file is not a DBB test (DBB formats: " +
                         kDbbFormat + ", " + kDbbCsvFormat + ")");
}

}  // namespace km::ingest
