#pragma once
// Text in self-contained HTML reports (calibration, contour): escaped for element text and
// attribute values.
#include <string>
#include <string_view>

namespace postproc::io {

[[nodiscard]] inline std::string html_escape(std::string_view s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '&': o += "&amp;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  }
  return o;
}

}  // namespace postproc::io
