// Small pieces of HTML for the report: escaping, base64 (images embedded as
// data: URIs, so the file is self-contained) and tables.
#ifndef MVBRDF_CORE_REPORT_HTML_H_
#define MVBRDF_CORE_REPORT_HTML_H_

#include <string>
#include <vector>

#include "absl/strings/string_view.h"

namespace mvbrdf::report {

std::string Escape(absl::string_view text);
std::string Base64(absl::string_view bytes);
// <img> with the PNG embedded.
std::string PngImg(absl::string_view png, const std::string& alt, int width = 0);
// A table of text: every header and cell is escaped (a cell is never HTML, so
// a camera or cluster name such as "<img src=x onerror=...>" stays text).
std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class = "");

}  // namespace mvbrdf::report

#endif  // MVBRDF_CORE_REPORT_HTML_H_
