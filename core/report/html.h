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
// header_titles (optional, per column; empty: none) become the headers'
// tooltips (title attributes, escaped).
std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class = "", const std::vector<std::string>& header_titles = {});
// <abbr title="TITLE">TEXT</abbr>, both escaped: a term with its definition
// as a tooltip (docs/glossary.md).
std::string Abbr(absl::string_view text, absl::string_view title);

}  // namespace mvbrdf::report

#endif  // MVBRDF_CORE_REPORT_HTML_H_
