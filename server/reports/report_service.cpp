#include "server/reports/report_service.h"

#include <optional>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/dbb/full_analysis.h"
#include "ingest/json_text.h"
#include "render/pdf_report.h"
#include "server/audits/audit_service.h"
#include "server/base/time_util.h"
#include "usecases/dbb_report.h"
#include "usecases/pdf_reports.h"

namespace km::server {
namespace {

usecases::ReportSource SourceOf(const MeasurementRecord& r) {
  usecases::ReportSource s;
  s.measurement_id = r.id;
  s.kind = r.kind;
  s.machine_id = r.machine_id;
  s.test_id = r.test_id;
  s.direction = r.direction;
  s.filename = r.filename;
  s.measured_at = r.measured_at.value_or("");
  s.uploaded_at = r.uploaded_at;
  if (!r.metadata_json.empty())
    s.metadata = ingest::ParseJsonText(r.metadata_json, "stored document");
  return s;
}

// The instrument line of a report from the stored result's `instrument` object (the file's keys
// completed from the instrument register, docs/http.md "Instruments"): name, serial,
// calibration date, certificate, when it was due and whether the register supplied values.
void NameInstrument(usecases::ReportSource& s, const nlohmann::json& result) {
  if (!result.is_object() || !result.contains("instrument")) return;
  const nlohmann::json& i = result["instrument"];
  if (!i.is_object()) return;
  const auto text = [&](const char* key) {
    return i.contains(key) && i[key].is_string() ? i[key].get<std::string>() : std::string();
  };
  std::string line = text("instrument").empty() ? "instrument" : text("instrument");
  if (!text("serial").empty()) line += ", serial " + text("serial");
  line += ", calibrated " + (text("calibrated").empty() ? "— (not stated)" : text("calibrated"));
  if (!text("certificate").empty()) line += ", certificate " + text("certificate");
  if (!text("calibration_due").empty()) line += ", due " + text("calibration_due");
  if (i.value("overdue", false)) line += " — PAST ITS CALIBRATION INTERVAL when measured";
  if (i.contains("register_version") && i["register_version"].is_number_integer()) {
    line += " (instrument register version " + i["register_version"].dump() + ")";
  }
  if (!s.metadata.is_object()) s.metadata = nlohmann::json::object();
  s.metadata["instrument"] = line;
}

// The machine's audit rules (null: none) and its newest verdict (null: none).
usecases::ReportAudit AuditOf(AuditSource& records, const std::string& machine_id) {
  usecases::ReportAudit a{nullptr, nullptr};
  if (records.storage().GetAuditConfig(machine_id)) a.config = AuditConfigJson(records, machine_id);
  AuditVerdictFilter f;
  f.machine_id = machine_id;
  f.limit = 1;
  const auto list = ListAccuracyAudits(records, f);
  if (!list.at("audits").empty()) a.verdict = list.at("audits").at(0);
  return a;
}

// The newest test of the same set-up (machine, kind, test and direction) measured after `r`: the
// machine as left.
std::optional<usecases::ReportLater> LaterOf(AuditSource& records, MeasurementService& ms,
                                             const MeasurementRecord& r) {
  MeasurementFilter f;
  f.machine_id = r.machine_id;
  f.kind = r.kind;
  f.test_id = r.test_id;
  if (!r.direction.empty()) f.direction = r.direction;
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = 1;
  const auto page = records.storage().ListMeasurements(f);
  if (page.items.empty() || page.items.front().id == r.id) return std::nullopt;
  const auto& n = page.items.front();
  const std::string then = n.measured_at.value_or(n.uploaded_at);
  if (then <= r.measured_at.value_or(r.uploaded_at)) return std::nullopt;
  return usecases::ReportLater{n.id, then, ms.Results(n.id)};
}

usecases::ReportContext ContextOf(AuditSource& records, MeasurementService& ms,
                                  const MeasurementRecord& r) {
  usecases::ReportContext c;
  c.printed_at = NowUtcIso8601();
  c.audit = AuditOf(records, r.machine_id);
  c.later = LaterOf(records, ms, r);
  c.conformance = ms.Conformance(r.id);
  return c;
}

}  // namespace

namespace {

render::RenderOptions Options(const std::function<bool()>& cancelled) {
  render::RenderOptions o;
  o.cancelled = cancelled;
  return o;
}

}  // namespace

std::string ReportService::DbbPdf(const MeasurementRecord& rec, const Cancelled& cancelled) {
  std::vector<dbb::DbbTest> tests{measurements_.LoadDbb(rec.id)};
  const auto partner = measurements_.DbbPartner(rec);
  if (partner) tests.push_back(measurements_.LoadDbb(*partner));
  const dbb::DbbReport report = dbb::AnalyzeDbbSet(tests);
  const nlohmann::json j = usecases::DbbReportJson(tests, report);
  usecases::ReportContext ctx = ContextOf(records_, measurements_, rec);
  ctx.partner_id = partner;
  usecases::ReportSource source = SourceOf(rec);
  NameInstrument(source, measurements_.Results(rec.id));
  return render::RenderPdf(usecases::DbbPdfReport(report, j, 0, source, ctx), Options(cancelled));
}

std::string ReportService::ResultsPdf(const MeasurementRecord& rec, const Cancelled& cancelled) {
  // A stop also ends a report between reading its data and laying it out (a large result takes
  // seconds to read before the render asks).
  const auto give_up = [&] {
    if (cancelled && cancelled()) {
      throw render::RenderCancelled(
          "the report was not finished: the server is stopping; retry shortly");
    }
  };
  const auto ctx = ContextOf(records_, measurements_, rec);
  give_up();
  const nlohmann::json results = measurements_.Results(rec.id);
  give_up();
  usecases::ReportSource source = SourceOf(rec);
  NameInstrument(source, results);
  render::Report report = usecases::ResultsPdfReport(results, source, ctx);
  give_up();
  return render::RenderPdf(report, Options(cancelled));
}

std::string ReportService::MeasurementPdf(std::int64_t id) {
  auto rec = records_.storage().GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  return gate_.Run([this, rec = std::move(*rec)](const Cancelled& cancelled) {
    return rec.kind == "dbb" ? DbbPdf(rec, cancelled) : ResultsPdf(rec, cancelled);
  });
}

std::string ReportService::JobPdf(std::int64_t id) {
  return gate_.Run([this, id](const Cancelled& cancelled) {
    return render::RenderPdf(usecases::JobPdfReport(studies_.Job(id), NowUtcIso8601()),
                             Options(cancelled));
  });
}

std::string ReportService::AuditPdf(const std::string& machine_id) {
  return gate_.Run([this, machine_id](const Cancelled& cancelled) {
    const auto a = AuditOf(records_, machine_id);
    AuditVerdictFilter f;
    f.machine_id = machine_id;
    f.limit = 50;
    const auto verdicts = ListAccuracyAudits(records_, f).at("audits");
    if (a.config.is_null() && verdicts.empty()) {
      throw NotFound("machine '" + machine_id + "' has no accuracy audit");
    }
    return render::RenderPdf(
        usecases::AuditPdfReport(machine_id, a.config, verdicts, NowUtcIso8601()),
        Options(cancelled));
  });
}

}  // namespace km::server
