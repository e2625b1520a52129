// Words and numbers of the PDF reports (usecases/pdf_reports.h): fixed decimals, the label and
// unit of a result key, a table of a result object's figures. Internal to usecases/.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/pdf_report.h"
#include "usecases/pdf_reports.h"

namespace km::usecases::report_text {

// v with `decimals` decimals; "—" for a missing, non-numeric or non-finite value.
std::string Fixed(const nlohmann::json& v, int decimals = 2);
std::string Fixed(double v, int decimals = 2);
// "circularity_um" → {"circularity", "µm"}; "angle_deg" → {"angle", "°"}.
struct KeyLabel {
  std::string label, unit;
};
KeyLabel LabelOf(const std::string& key);
// A JSON value as short text (a number with 3 decimals, a string as is, an array of numbers
// "(a, b, c)").
std::string Short(const nlohmann::json& v);
// The time as written by the API, or "—".
std::string When(const std::string& iso);
// Rows Figure | value | unit of every number (and array of up to 3 numbers) of an object, its
// nested objects' with "parent." before the key, skipping `skip`.
render::ReportTable FiguresTable(const nlohmann::json& object,
                                 const std::vector<std::string>& skip = {});
// Tables of the objects of `object` whose members are arrays of equal length (columns), e.g.
// the targets of a positioning test; each with its key as heading.
std::vector<render::ReportBlock> ColumnTables(const nlohmann::json& object);
// The identification lines every measurement report starts with.
std::vector<std::pair<std::string, std::string>> Identification(const ReportSource& s);
// The audit section of a measurement report: the rules of `kind`, limits, values, the verdict.
std::vector<render::ReportBlock> AuditBlocks(const ReportAudit& audit, const std::string& kind);
std::string Footer(const std::string& what, const std::string& printed_at);

}  // namespace km::usecases::report_text
