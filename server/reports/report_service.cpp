#include "server/reports/report_service.h"

#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/dbb/full_analysis.h"
#include "ingest/json_text.h"
#include "render/pdf_report.h"
#include "server/audits/audit_service.h"
#include "server/base/errors.h"
#include "server/base/time_util.h"
#include "usecases/dbb_report.h"
#include "usecases/pdf_reports.h"

namespace km::server {
namespace {

usecases::ReportSource SourceOf(const MeasurementRecord& r) {
  usecases::ReportSource s;
  s.measurement_id = r.id.value();
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
  if (!text("kind").empty()) line += " (" + text("kind") + ")";
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
  if (records.audit_store().GetAuditConfig(machine_id))
    a.config = AuditConfigJson(records, machine_id);
  AuditVerdictFilter f;
  f.machine_id = machine_id;
  f.limit = 1;
  const auto list = ListAccuracyAudits(records, f);
  if (!list.at("audits").empty()) a.verdict = list.at("audits").at(0);
  return a;
}

// The test the user chose as the machine as left: another test of the same set-up (machine,
// kind, test and direction) measured after `r`; InvalidInput naming `as_left` otherwise.
usecases::ReportLater ChosenLater(AuditSource& records, MeasurementService& ms,
                                  const MeasurementRecord& r, MeasurementId as_left) {
  const auto refuse = [&](const std::string& why) {
    return InvalidInput("", 0, "as_left", "measurement " + to_string(as_left) + " " + why);
  };
  const auto n = records.measurement_store().GetMeasurement(as_left);
  if (!n) throw refuse("does not exist");
  if (n->id == r.id) throw refuse("is the as-found test itself; choose a later test");
  if (n->machine_id != r.machine_id || n->kind != r.kind || n->test_id != r.test_id ||
      n->direction != r.direction) {
    throw refuse("is not a test of the same set-up (machine " + r.machine_id + ", " + r.kind +
                 " test " + r.test_id + (r.direction.empty() ? "" : " " + r.direction) + ")");
  }
  const std::string then = n->measured_at.value_or(n->uploaded_at);
  if (then <= r.measured_at.value_or(r.uploaded_at)) {
    throw refuse("was not measured after the as-found test (" + then + ")");
  }
  return usecases::ReportLater{n->id.value(), then, ms.Results(n->id)};
}

usecases::ReportContext ContextOf(AuditSource& records, MeasurementService& ms,
                                  const MeasurementRecord& r,
                                  std::optional<usecases::ReportLater> later) {
  usecases::ReportContext c;
  c.printed_at = NowUtcIso8601();
  c.audit = AuditOf(records, r.machine_id);
  c.later = std::move(later);
  c.conformance = ms.Conformance(r.id);
  return c;
}

// What a measurement's certificate summarises: the ids and versions it was made from.
nlohmann::json SummaryOf(const MeasurementRecord& r, const nlohmann::json& results,
                         const nlohmann::json& conformance,
                         const std::optional<usecases::ReportLater>& later) {
  nlohmann::json s{{"measurement_id", r.id}};
  if (later) s["as_left_id"] = later->measurement_id;
  if (conformance.is_object() && conformance.contains("tolerance_version")) {
    s["tolerance_version"] = conformance["tolerance_version"];
  }
  if (results.is_object() && results.contains("instrument") && results["instrument"].is_object() &&
      results["instrument"].contains("register_version")) {
    s["instrument_register_version"] = results["instrument"]["register_version"];
  }
  return s;
}

}  // namespace

namespace {

render::RenderOptions Options(const std::function<bool()>& cancelled) {
  render::RenderOptions o;
  o.cancelled = cancelled;
  return o;
}

}  // namespace

ReportService::Prepared ReportService::PrepareMeasurement(MeasurementId id,
                                                          std::optional<MeasurementId> as_left) {
  auto found = records_.measurement_store().GetMeasurement(id);
  if (!found) throw NotFound("measurement " + to_string(id) + " does not exist");
  MeasurementRecord rec = std::move(*found);
  std::optional<usecases::ReportLater> later;
  if (as_left) later = ChosenLater(records_, measurements_, rec, *as_left);
  auto ctx = std::make_shared<usecases::ReportContext>(
      ContextOf(records_, measurements_, rec, std::move(later)));
  auto results = std::make_shared<nlohmann::json>(measurements_.Results(rec.id));
  Prepared p;
  p.subject = MeasurementCertificate(id, as_left);
  p.content = {
      {"measurement", rec.sha256}, {"results", *results}, {"conformance", ctx->conformance}};
  if (ctx->later) {
    p.content["as_left"] = {{"id", ctx->later->measurement_id}, {"results", ctx->later->results}};
  }
  if (rec.kind == "dbb") {
    if (const auto partner = measurements_.DbbPartner(rec)) {
      ctx->partner_id = partner->value();
      p.content["partner"] = {{"id", *partner}, {"results", measurements_.Results(*partner)}};
    }
  }
  p.summary = SummaryOf(rec, *results, ctx->conformance, ctx->later);
  p.build = [this, rec = std::move(rec), ctx, results](const Cancelled&) {
    usecases::ReportSource source = SourceOf(rec);
    NameInstrument(source, *results);
    if (rec.kind != "dbb") return usecases::ResultsPdfReport(*results, source, *ctx);
    std::vector<dbb::DbbTest> tests{measurements_.LoadDbb(rec.id)};
    if (ctx->partner_id) tests.push_back(measurements_.LoadDbb(MeasurementId(*ctx->partner_id)));
    const dbb::DbbReport report = dbb::AnalyzeDbbSet(tests);
    nlohmann::json j = usecases::DbbReportJson(tests, report);
    // Each test's uncertainty as its stored result gives it (the API, the page and the
    // conformance read that one; the pair's own draws would differ within the Monte Carlo's
    // precision).
    const auto stored_u = [&](std::size_t i, const nlohmann::json& r) {
      if (r.is_object() && r.contains("uncertainty") && i < j["tests"].size()) {
        j["tests"][i]["uncertainty"] = r["uncertainty"];
      }
    };
    stored_u(0, *results);
    if (ctx->partner_id) stored_u(1, measurements_.Results(MeasurementId(*ctx->partner_id)));
    return usecases::DbbPdfReport(report, j, 0, source, *ctx);
  };
  return p;
}

ReportService::Prepared ReportService::PrepareJob(JobId id) {
  nlohmann::json job = studies_.Job(id);
  Prepared p;
  p.subject = JobCertificate(id);
  p.content = {{"id", id}};
  for (const char* key : {"kind", "status", "request", "result", "error", "verdict"}) {
    if (job.contains(key)) p.content[key] = job[key];
  }
  p.summary = {{"job_id", id}, {"status", job.value("status", "")}};
  p.build = [job = std::move(job)](const Cancelled&) {
    return usecases::JobPdfReport(job, NowUtcIso8601());
  };
  return p;
}

ReportService::Prepared ReportService::PrepareAudit(const std::string& machine_id) {
  const auto a = AuditOf(records_, machine_id);
  AuditVerdictFilter f;
  f.machine_id = machine_id;
  f.limit = 50;
  nlohmann::json verdicts = ListAccuracyAudits(records_, f).at("audits");
  if (a.config.is_null() && verdicts.empty()) {
    throw NotFound("machine '" + machine_id + "' has no accuracy audit");
  }
  Prepared p;
  p.subject = AuditCertificate(machine_id);
  const nlohmann::json newest = verdicts.empty() ? nlohmann::json() : verdicts.at(0);
  p.content = {{"machine_id", machine_id}, {"config", a.config}, {"newest_verdict", newest}};
  p.summary = {{"machine_id", machine_id},
               {"newest_verdict_id",
                newest.is_object() ? newest.value("id", nlohmann::json()) : nlohmann::json()}};
  p.build = [machine_id, config = a.config, verdicts = std::move(verdicts)](const Cancelled&) {
    return usecases::AuditPdfReport(machine_id, config, verdicts, NowUtcIso8601());
  };
  return p;
}

std::string ReportService::Pdf(const std::function<Prepared()>& prepare,
                               std::optional<std::int64_t> revision) {
  // By value: a stopping server answers the caller before the gate's thread has finished.
  return gate_.Run([this, prepare, revision](const Cancelled& cancelled) {
    const Prepared p = prepare();
    const ReportRevisionRecord current = certificates_.Current(p.subject, p.content, p.summary);
    if (revision && *revision != current.revision) {
      return certificates_.ApprovedPdf(p.subject, *revision, current.revision);
    }
    if (current.approval) return certificates_.ApprovedPdf(p.subject, current.revision, 0);
    render::Report r = p.build(cancelled);
    usecases::AddCertificate(r, certificates_.Printed(p.subject, current));
    return render::RenderPdf(r, Options(cancelled));
  });
}

nlohmann::json ReportService::Approve(const CertificateSubject& subject,
                                      const std::function<Prepared()>& prepare,
                                      std::optional<std::int64_t> revision,
                                      const ReportApprover& by) {
  // Before the report is made again (in the render gate): a revision already approved or
  // superseded is answered at once.
  if (revision) certificates_.CheckNamedRevision(subject, *revision);
  return nlohmann::json::parse(gate_.Run([this, prepare, revision, by](const Cancelled& cancelled) {
    const Prepared p = prepare();
    const ReportRevisionRecord current = certificates_.Current(p.subject, p.content, p.summary);
    certificates_.CheckApprovable(p.subject, current, revision);
    const std::string at = NowUtcIso8601();
    usecases::ReportCertificate c = certificates_.Printed(p.subject, current);
    c.approved_by = by.name;
    c.approved_at = at;
    render::Report r = p.build(cancelled);
    usecases::AddCertificate(r, c);
    return certificates_
        .Approve(p.subject, current, by, at, render::RenderPdf(r, Options(cancelled)))
        .dump();
  }));
}

nlohmann::json ReportService::Revisions(const Prepared& p) {
  return certificates_.Revisions(p.subject, certificates_.Current(p.subject, p.content, p.summary));
}

std::string ReportService::MeasurementPdf(MeasurementId id, const ReportRequest& q) {
  return Pdf([this, id, as_left = q.as_left] { return PrepareMeasurement(id, as_left); },
             q.revision);
}

std::string ReportService::JobPdf(JobId id, std::optional<std::int64_t> revision) {
  return Pdf([this, id] { return PrepareJob(id); }, revision);
}

std::string ReportService::AuditPdf(const std::string& machine_id,
                                    std::optional<std::int64_t> revision) {
  return Pdf([this, machine_id] { return PrepareAudit(machine_id); }, revision);
}

nlohmann::json ReportService::MeasurementRevisions(MeasurementId id,
                                                   std::optional<MeasurementId> as_left) {
  return Revisions(PrepareMeasurement(id, as_left));
}

nlohmann::json ReportService::JobRevisions(JobId id) {
  return Revisions(PrepareJob(id));
}

nlohmann::json ReportService::AuditRevisions(const std::string& machine_id) {
  return Revisions(PrepareAudit(machine_id));
}

nlohmann::json ReportService::ApproveMeasurement(MeasurementId id,
                                                 std::optional<MeasurementId> as_left,
                                                 std::optional<std::int64_t> revision,
                                                 const ReportApprover& by) {
  return Approve(
      MeasurementCertificate(id, as_left),
      [this, id, as_left] { return PrepareMeasurement(id, as_left); }, revision, by);
}

nlohmann::json ReportService::ApproveJob(JobId id, std::optional<std::int64_t> revision,
                                         const ReportApprover& by) {
  return Approve(
      JobCertificate(id),
      [this, id] {
        Prepared p = PrepareJob(id);
        if (p.content.value("status", "") != "done") {
          throw Conflict("job " + to_string(id) + " is " + p.content.value("status", "") +
                         ": a job's report is approved when the job is done");
        }
        return p;
      },
      revision, by);
}

nlohmann::json ReportService::ApproveAudit(const std::string& machine_id,
                                           std::optional<std::int64_t> revision,
                                           const ReportApprover& by) {
  return Approve(
      AuditCertificate(machine_id), [this, machine_id] { return PrepareAudit(machine_id); },
      revision, by);
}

}  // namespace km::server
