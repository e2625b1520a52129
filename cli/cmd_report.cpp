// `kinemetric report FILE… --out OUT.pdf` (docs/formats.md §3.16): the PDF report of a
// measurement file, as the service draws it for a stored measurement (usecases/pdf_reports.h),
// without what only the service knows (stored ids, the machine's audit, later tests). A DBB
// file may come with its opposite-direction partner as a second file.
#include <chrono>
#include <ctime>
#include <fstream>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/dbb/full_analysis.h"
#include "cli/command.h"
#include "ingest/file_formats.h"
#include "ingest/form_parsers.h"
#include "ingest/positioning_parser.h"
#include "ingest/text_format.h"
#include "ingest/tracker_parser.h"
#include "render/pdf_report.h"
#include "usecases/dbb_report.h"
#include "usecases/form_report.h"
#include "usecases/pdf_reports.h"
#include "usecases/positioning_report.h"
#include "usecases/tracker_report.h"

namespace km::cli {
namespace {

std::string NowIso() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// Where the report's measurement came from: the file's header keys.
usecases::ReportSource SourceOf(const std::map<std::string, std::string>& metadata,
                                const std::string& path, const std::string& kind) {
  usecases::ReportSource s;
  s.kind = kind;
  s.filename = path;
  s.metadata = nlohmann::json::object();
  for (const auto& [k, v] : metadata) s.metadata[k] = v;
  const auto get = [&](const char* key) {
    return s.metadata.contains(key) ? s.metadata[key].get<std::string>() : std::string();
  };
  s.machine_id = get("machine_id");
  s.test_id = kind == "positioning" || kind == "straightness" || kind == "parallelism"
                  ? get("axis")
                  : get("test_id");
  s.direction = get("direction");
  s.measured_at = get("timestamp");
  return s;
}

usecases::ReportSource SourceOf(const std::string& bytes, const std::string& path,
                                const std::string& kind) {
  // The header is what is wanted; the data rows are checked, not kept (a positioning file's
  // direction column holds the words + and -).
  ingest::ReadOptions options;
  options.keep_column = [](std::string_view) { return false; };
  if (kind == "positioning") options.word_columns["direction"] = {{"+", 1.0}, {"-", -1.0}};
  return SourceOf(ingest::ReadTextTable(bytes, path, options).Metadata(), path, kind);
}

render::Report DbbReport(const Args& args, const std::string& printed_at) {
  if (args.positional.size() > 2) {
    throw InvalidInput("", 0, "FILE", "a DBB report takes one test and at most its partner");
  }
  std::vector<dbb::DbbTest> tests;
  for (const auto& path : args.positional) {
    tests.push_back(ingest::ReadDbb(ReadFileBytes(path), path));
  }
  const dbb::DbbReport report = dbb::AnalyzeDbbSet(tests);
  const auto j = usecases::DbbReportJson(tests, report);
  const auto& first = args.positional.front();
  usecases::ReportContext ctx;
  ctx.printed_at = printed_at;
  // The source from the test read (any DBB format): its header keys are the file's.
  return usecases::DbbPdfReport(report, j, 0, SourceOf(tests.front().metadata, first, "dbb"), ctx);
}

// The result object of one file of another kind, as `kinemetric … --json` prints it.
nlohmann::json ResultOf(const std::string& format, const std::string& bytes,
                        const std::string& path, std::string& kind) {
  if (format == ingest::kStraightnessFormat) {
    kind = "straightness";
    return usecases::StraightnessFilesToJson({ingest::ParseStraightnessFile(bytes, path)});
  }
  if (format == ingest::kFlatnessFormat) {
    kind = "flatness";
    return usecases::FlatnessFileToJson(ingest::ParseFlatnessFile(bytes, path));
  }
  if (format == ingest::kParallelismFormat) {
    kind = "parallelism";
    return usecases::ParallelismFileToJson(ingest::ParseParallelismFile(bytes, path));
  }
  if (format == ingest::kPositioningFormat) {
    kind = "positioning";
    return usecases::PositioningReportToJson(
        usecases::AnalyzePositioning(ingest::ParsePositioningFile(bytes, path)));
  }
  if (format == ingest::kTrackerFormat) {
    kind = "tracker";
    return usecases::AnalyzeTracker(ingest::ParseTrackerFile(bytes, path));
  }
  throw InvalidInput(path, 1, "format",
                     "no report for format '" + format +
                         "'; reports are made of DBB, straightness, flatness, parallelism, "
                         "positioning and tracker files");
}

int RunReport(const Args& args, std::ostream& out) {
  if (args.positional.empty()) throw InvalidInput("", 0, "FILE", "give the measurement file");
  const auto target = args.Get("--out");
  if (!target || target->empty()) throw InvalidInput("", 0, "--out", "give --out OUT.pdf");
  const std::string printed_at = NowIso();
  const auto& first = args.positional.front();
  const std::string bytes = ReadFileBytes(first);
  const ingest::FileFormat& recognised = ingest::RecogniseFormat(bytes, first);
  const std::string format(recognised.name);
  render::Report report;
  if (recognised.kind == "dbb") {
    report = DbbReport(args, printed_at);
  } else {
    if (args.positional.size() > 1) {
      throw InvalidInput("", 0, "FILE", "a " + format + " report takes one file");
    }
    std::string kind;
    const auto result = ResultOf(format, bytes, first, kind);
    usecases::ReportContext ctx;
    ctx.printed_at = printed_at;
    report = usecases::ResultsPdfReport(result, SourceOf(bytes, first, kind), ctx);
  }
  const std::string pdf = render::RenderPdf(report);
  std::ofstream f(*target, std::ios::binary);
  f.write(pdf.data(), static_cast<std::streamsize>(pdf.size()));
  if (!f.good()) throw InvalidInput(*target, 0, "--out", "cannot write the report there");
  out << "wrote " << *target << " (" << pdf.size() << " bytes): " << report.title << "\n";
  return 0;
}

}  // namespace

KM_CLI_COMMAND("report", "FILE [PARTNER_FILE] --out OUT.pdf", {"--out"}, RunReport);

}  // namespace km::cli
