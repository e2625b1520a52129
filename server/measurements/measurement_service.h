// The stored measurements: uploads of every registered format (validated, analysed and stored
// at once), their results, the lists the page shows, and the queries recomputed from a stored
// file (the DBB trace, CW/CCW pair and polar plot; the straightness reversal of a pair).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/dbb/dbb_types.h"
#include "ingest/text_format.h"
#include "render/polar_plot.h"
#include "server/measurements/conformance_hook.h"
#include "server/measurements/ingested.h"
#include "server/measurements/instrument_hook.h"
#include "server/measurements/parsed_results.h"
#include "server/measurements/results_answers.h"
#include "server/storage/storage.h"

namespace km::server {

// What an upload of each format may hold, by format name (e.g. "kinemetric-dbb/1"): data rows,
// line length, columns, values, header and marker lines (ingest/text_format.h). The defaults
// keep the analysis done at upload within about 2 s of CPU and the parse within about 2× the
// file size: DBB 500 000 samples (the analysis costs about 3 µs and 400 bytes a sample);
// straightness 100 000 points (its periodic-component search costs about 10 µs a point);
// parallelism and flatness 1 000 000 points; tracker 10 000 points, 24 columns and 80 000
// values in all (the self-calibration costs about 0.15 ms a point with 4 to 8 trackers, 0.45 ms
// with 16). Every format: lines of at most 4 KiB, 1 000 header lines, 1 000 '#' lines among the
// data.
std::map<std::string, ingest::TextLimits> DefaultUploadLimits();

struct UploadOptions {
  // The largest upload, in bytes.
  std::size_t max_upload_bytes = 32u << 20;
  // Checked in one pass before anything is parsed; an upload beyond them is refused with
  // km::TooLarge (HTTP 413) naming the file and the first line beyond the limit. A format
  // without an entry gets the TextLimits defaults.
  std::map<std::string, ingest::TextLimits> upload_limits = DefaultUploadLimits();
};

struct UploadOutcome {
  MeasurementId id;
  bool created = false;
  std::string sha256;
  std::string kind;
  // The measurement's conformance with its machine's newest tolerances (null without judges).
  nlohmann::json conformance = nullptr;
};

class MeasurementService {
 public:
  MeasurementService(MeasurementStore& store, UploadOptions options);

  // Registers the handler of a format name (e.g. "kinemetric-dbb/1").
  void RegisterKind(const std::string& format, KindHandler handler);
  std::vector<std::string> Formats() const;

  // Validates, analyses and stores. Same bytes again → the existing id, created = false.
  // Nothing is stored when the input is bad (km::InvalidInput / km::TooLarge).
  UploadOutcome Upload(std::string_view bytes, const std::string& filename);

  // Judges measurements against their machine's newest tolerances from now on: the upload
  // answer, MeasurementWithSamples, ResultsWithConformance and every item of ListMeasurements
  // carry "conformance" (server/measurements/conformance_hook.h). Set once, before serving.
  // A judge's verdict may depend on the measurement's result and its machine's newest
  // tolerance table only: ResultsAnswer keeps answers made with them (results_answers.h).
  void SetConformanceJudges(ConformanceJudges judges) { judges_ = std::move(judges); }
  // Completes each uploaded file naming an instrument from the instrument register before its
  // analysis; its result then carries "instrument" (server/measurements/instrument_hook.h). Set
  // once, before serving.
  void SetInstrumentHook(InstrumentHook hook) { instruments_ = std::move(hook); }

  // Results as the CLI prints them (the newest analysis version of each analysis).
  nlohmann::json Results(MeasurementId id);
  // The same object with "conformance" added (GET /api/v1/measurements/{id}/results).
  nlohmann::json ResultsWithConformance(MeasurementId id);
  // The same, serialised as the HTTP answer (invalid UTF-8 replaced): kept and served again
  // while the measurement's results and its machine's tolerance table are unchanged in storage.
  std::shared_ptr<const std::string> ResultsAnswer(MeasurementId id);
  // The conformance of a stored measurement (null without judges); NotFound.
  nlohmann::json Conformance(MeasurementId id);
  nlohmann::json MeasurementJson(const MeasurementRecord& r) const;
  // Measurement metadata matching the filter: {"items": [MeasurementJson… + "key_result",
  // "conformance"], "total"}.
  nlohmann::json ListMeasurements(const MeasurementFilter& filter);
  // One measurement: MeasurementJson plus "metadata", "samples" (one array per column),
  // "partner_id" (PartnerOf, or null) and "conformance"; NotFound when there is none.
  nlohmann::json MeasurementWithSamples(MeasurementId id);
  // Machines with stored measurements or a stored model.
  std::vector<MachineSummary> Machines();

  // DBB queries, recomputed from the stored bytes: the plot data of the evaluated turn; the
  // CW/CCW pair analysis with the opposite-direction test of the same machine and test_id
  // (null when there is none); the polar plot PNG (both directions when the partner exists).
  nlohmann::json DbbTrace(MeasurementId id);
  nlohmann::json DbbPairJson(MeasurementId id);
  std::string DbbPlotPng(MeasurementId id, const render::PolarPlotOptions& options = {});
  // Straightness reversal of a stored profile with the other set-up of its pair (same machine
  // and pair_id, measured nearest in time): {partner_id, reversal{...}, profiles[]}; null when
  // the other set-up is not stored.
  nlohmann::json StraightnessReversalJson(MeasurementId id);

  // The compensation table a controller loads, from a stored laser positioning test
  // (usecases/positioning_export.h): format linuxcnc, sinumerik or csv (InvalidInput naming
  // `format` otherwise; NotFound; InvalidInput for a measurement of another kind).
  std::string PositioningCompensation(MeasurementId id, const std::string& format);

  // A stored DBB test, parsed from its stored bytes (NotFound; InvalidInput when the
  // measurement is of another kind); `record` receives its record when given.
  dbb::DbbTest LoadDbb(MeasurementId id, MeasurementRecord* record = nullptr);
  // The stored opposite-direction test of a DBB test (same machine and test, nearest in time);
  // none when there is none.
  std::optional<MeasurementId> DbbPartner(const MeasurementRecord& rec);
  // The measurement GET …/pair (a DBB test) or GET …/reversal (a straightness set-up a or b)
  // pairs this one with; none for other kinds or when the partner is not stored.
  std::optional<MeasurementId> PartnerOf(const MeasurementRecord& rec);

 private:
  std::optional<MeasurementId> NearestPartner(const MeasurementRecord& rec,
                                              const std::string& other_direction);

  // The conformance of a measurement from its stored results, by a judge of judges_.
  nlohmann::json Judge(const ConformanceJudge& judge, const MeasurementRecord& r,
                       const std::vector<ResultRecord>& results) const;

  MeasurementStore& store_;
  UploadOptions options_;
  std::map<std::string, KindHandler> kinds_;
  ConformanceJudges judges_;
  ResultsAnswers answers_;  // GET …/results answers, each with what it was made from
  InstrumentHook instruments_;
  mutable ParsedResults parsed_;  // the stored results' documents, parsed once
  // What a measurement's conformance is judged as (machine, kind, set-up), by id: a stored
  // measurement never changes, so an entry never goes stale; emptied when it holds 4096.
  ConformanceSubject CachedSubject(MeasurementId id);
  std::mutex subjects_mu_;
  std::unordered_map<MeasurementId, ConformanceSubject> subjects_;
};

// The handlers of every measurement kind the product knows; call once at start-up.
void RegisterBuiltinKinds(MeasurementService& measurements);

}  // namespace km::server
