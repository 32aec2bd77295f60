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

std::string Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& css_class) {
  std::string out = css_class.empty() ? "<table>" : "<table class=\"" + Escape(css_class) + "\">";
  out += "<thead><tr>";
  for (const std::string& h : header) out += "<th>" + Escape(h) + "</th>";
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
