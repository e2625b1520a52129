#include "server/reports/certificates.h"

#include <cstdio>

#include "analysis/core/errors.h"
#include "server/base/errors.h"
#include "server/base/sha256.h"
#include "server/base/time_util.h"

namespace km::server {
namespace {

using nlohmann::json;

std::string Padded(std::int64_t id) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06lld", static_cast<long long>(id));
  return buf;
}

// A machine id in a certificate number: letters, digits, '.', '-' and '_' (anything else '_').
std::string Plain(std::string s) {
  for (auto& c : s) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '.' || c == '-' || c == '_';
    if (!plain) c = '_';
  }
  return s;
}

std::string Name(const CertificateSubject& s, std::int64_t revision) {
  return "revision " + std::to_string(revision) + " of certificate " + s.number;
}

}  // namespace

CertificateSubject MeasurementCertificate(MeasurementId id, std::optional<MeasurementId> as_left) {
  CertificateSubject s{"measurement " + to_string(id), "KM-M" + Padded(id.value())};
  if (as_left) {
    s.subject += " as-left " + to_string(*as_left);
    s.number += "-L" + Padded(as_left->value());
  }
  return s;
}

CertificateSubject JobCertificate(JobId id) {
  return {"job " + to_string(id), "KM-J" + Padded(id.value())};
}

CertificateSubject AuditCertificate(const std::string& machine_id) {
  return {"audit " + machine_id, "KM-A-" + Plain(machine_id.substr(0, 64))};
}

ReportRevisionRecord Certificates::Current(const CertificateSubject& s, const json& content,
                                           const json& summary) {
  NewReportRevision n{s.subject, Sha256Hex(content.dump()), summary.dump()};
  return store_.PutReportRevision(n).record;
}

usecases::ReportCertificate Certificates::Printed(const CertificateSubject& s,
                                                  const ReportRevisionRecord& r) {
  usecases::ReportCertificate c;
  c.number = s.number;
  c.revision = r.revision;
  if (r.approval) {
    c.approved_by = r.approval->approved_by;
    c.approved_at = r.approval->approved_at;
  }
  for (const auto& e : store_.ListReportRevisions(s.subject)) {
    if (e.revision < r.revision && e.approval) {
      c.supersedes = "revision " + std::to_string(e.revision) + ", approved by " +
                     e.approval->approved_by + " at " + e.approval->approved_at;
    }
  }
  return c;
}

json Certificates::Revisions(const CertificateSubject& s, const ReportRevisionRecord& current) {
  json list = json::array();
  for (const auto& e : store_.ListReportRevisions(s.subject)) {
    json j{{"revision", e.revision},
           {"created_at", e.created_at},
           {"summary", json::parse(e.summary_json, nullptr, false)}};
    if (e.approval) {
      j["approved_by"] = e.approval->approved_by;
      j["approved_at"] = e.approval->approved_at;
    }
    list.push_back(std::move(j));
  }
  return {{"certificate", s.number},
          {"subject", s.subject},
          {"current_revision", current.revision},
          {"revisions", std::move(list)}};
}

std::string Certificates::ApprovedPdf(const CertificateSubject& s, std::int64_t revision,
                                      std::int64_t current) {
  if (auto pdf = store_.ReportApprovalPdf(s.subject, revision)) return *pdf;
  if (revision < 1 || revision > current) {
    throw NotFound(Name(s, revision) + " does not exist; the current revision is " +
                   std::to_string(current));
  }
  throw NotFound(Name(s, revision) +
                 " was not approved: only approved revisions are kept as printed; the current "
                 "revision is " +
                 std::to_string(current));
}

void Certificates::CheckNamedRevision(const CertificateSubject& s, std::int64_t revision) {
  const auto list = store_.ListReportRevisions(s.subject);
  for (const auto& e : list) {
    if (e.revision == revision && e.approval) {
      throw Conflict(Name(s, revision) + " is already approved by " + e.approval->approved_by +
                     " at " + e.approval->approved_at);
    }
  }
  if (!list.empty() && revision < list.back().revision) {
    throw Conflict(Name(s, revision) + " is not the current revision (" +
                   std::to_string(list.back().revision) + " is)");
  }
}

void Certificates::CheckApprovable(const CertificateSubject& s, const ReportRevisionRecord& current,
                                   std::optional<std::int64_t> expected) {
  if (expected && *expected != current.revision) {
    throw Conflict(Name(s, *expected) + " is not the current revision (" +
                   std::to_string(current.revision) +
                   " is); read the current revision and approve that one");
  }
  if (current.approval) {
    throw Conflict(Name(s, current.revision) + " is already approved by " +
                   current.approval->approved_by + " at " + current.approval->approved_at);
  }
}

json Certificates::Approve(const CertificateSubject& s, const ReportRevisionRecord& current,
                           const ReportApprover& by, const std::string& at,
                           const std::string& pdf) {
  ReportApprovalRecord a{s.subject, current.revision, by.name, by.token_id, at, pdf};
  if (!store_.AddReportApproval(a)) {
    throw Conflict(Name(s, current.revision) + " was approved by another request first");
  }
  return {{"certificate", s.number}, {"subject", s.subject}, {"revision", current.revision},
          {"approved_by", by.name},  {"approved_at", at},    {"token_id", by.token_id},
          {"pdf_bytes", pdf.size()}};
}

}  // namespace km::server
