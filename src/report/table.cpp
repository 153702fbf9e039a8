#include "quadid/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace quadid::report {

namespace {

// Display width of a UTF-8 string (counts code points, which is right for the
// Greek letters and degree signs the tables use).
size_t display_width(const std::string& s) {
  size_t n = 0;
  for (unsigned char c : s)
    if ((c & 0xC0) != 0x80) ++n;
  return n;
}

std::string pad(const std::string& s, size_t w, bool left) {
  const size_t d = display_width(s);
  if (d >= w) return s;
  return left ? s + std::string(w - d, ' ') : std::string(w - d, ' ') + s;
}

}  // namespace

std::string html_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "n/a";
  return fmt::format("{:.{}f}", v, digits);
}

std::string sig(double v, int digits) {
  if (!std::isfinite(v)) return "n/a";
  if (v == 0.0) return "0";
  const int mag = static_cast<int>(std::floor(std::log10(std::abs(v))));
  const int decimals = std::max(0, digits - 1 - mag);
  if (mag < -4 || mag > 6) return fmt::format("{:.{}e}", v, digits - 1);
  return fmt::format("{:.{}f}", v, decimals);
}

std::string Table::to_text() const {
  const size_t nc = header.size();
  std::vector<size_t> w(nc, 0);
  for (size_t c = 0; c < nc; ++c) w[c] = display_width(header[c]);
  for (const auto& r : rows)
    for (size_t c = 0; c < nc && c < r.size(); ++c) w[c] = std::max(w[c], display_width(r[c]));
  std::string out;
  if (!title.empty()) out += title + "\n";
  auto line = [&](const std::vector<std::string>& cells) {
    std::string s;
    for (size_t c = 0; c < nc; ++c) {
      if (c) s += "  ";
      s += pad(c < cells.size() ? cells[c] : "", w[c], c == 0);
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s + "\n";
  };
  out += line(header);
  size_t total = 0;
  for (size_t c = 0; c < nc; ++c) total += w[c] + (c ? 2 : 0);
  out += std::string(total, '-') + "\n";
  for (const auto& r : rows) out += line(r);
  if (!note.empty()) out += note + "\n";
  return out;
}

std::string markdown_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    if (c == '|' || c == '\\') out += '\\';  // a bare | would end the cell
    out += c == '\n' ? ' ' : c;               // a newline would end the row
  }
  return out;
}

std::string Table::to_markdown() const {
  auto row = [](const std::vector<std::string>& cells) {
    std::string line = "|";
    for (const auto& c : cells) {
      line += ' ';
      line += markdown_escape(c);
      line += " |";
    }
    line += '\n';
    return line;
  };
  std::string out;
  if (!title.empty()) {
    out += "**";
    out += markdown_escape(title);
    out += "**\n\n";
  }
  out += row(header) + "|";
  for (size_t c = 0; c < header.size(); ++c) out += c == 0 ? "---|" : "---:|";
  out += "\n";
  for (const auto& r : rows) out += row(r);
  if (!note.empty()) out += "\n" + note + "\n";
  return out;
}

std::string Table::to_html() const {
  std::string out = "<table>\n";
  if (!title.empty()) out += "<caption>" + html_escape(title) + "</caption>\n";
  out += "<thead><tr>";
  for (const auto& h : header) out += "<th>" + html_escape(h) + "</th>";
  out += "</tr></thead>\n<tbody>\n";
  for (const auto& r : rows) {
    out += "<tr>";
    for (size_t c = 0; c < r.size(); ++c) {
      std::string cls;
      // Negative improvement percentages in red, positive in blue, as in the paper.
      if (c > 0 && c < header.size() && header[c].find("P_imp") != std::string::npos && !r[c].empty())
        cls = r[c][0] == '-' ? " class=\"neg\"" : " class=\"pos\"";
      out += (c == 0 ? "<th>" : "<td" + cls + ">") + html_escape(r[c]) + (c == 0 ? "</th>" : "</td>");
    }
    out += "</tr>\n";
  }
  out += "</tbody></table>\n";
  if (!note.empty()) out += "<p class=\"note\">" + html_escape(note) + "</p>\n";
  return out;
}

}  // namespace quadid::report
