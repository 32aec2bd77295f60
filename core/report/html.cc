#include "core/report/html.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::report {

std::string Escape(absl::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Base64(absl::string_view bytes) { return absl::Base64Escape(bytes); }

std::string PngImg(absl::string_view png, const std::string& alt, int width) {
  return absl::StrCat("<img src=\"data:image/png;base64,", Base64(png), "\" alt=\"", Escape(alt), "\"",
                      width > 0 ? absl::StrCat(" width=\"", width, "\"") : "", ">");
}

std::string Abbr(absl::string_view text, absl::string_view title) {
  return absl::StrCat("<abbr title=\"", Escape(title), "\">", Escape(text), "</abbr>");
}

std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class, const std::vector<std::string>& header_titles) {
  std::string out = css_class.empty() ? "<table>" : "<table class=\"" + Escape(css_class) + "\">";
  out += "<thead><tr>";
  for (size_t i = 0; i < header.size(); ++i) {
    const bool titled = i < header_titles.size() && !header_titles[i].empty();
    out += (titled ? "<th title=\"" + Escape(header_titles[i]) + "\">" : std::string("<th>")) + Escape(header[i]) +
           "</th>";
  }
  out += "</tr></thead><tbody>";
  for (const auto& row : rows) {
    out += "<tr>";
    for (const std::string& cell : row) out += "<td>" + Escape(cell) + "</td>";
    out += "</tr>";
  }
  out += "</tbody></table>";
  return out;
}

}  // namespace mvbrdf::report
