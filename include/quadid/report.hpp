// Reports for people: text and Markdown tables for the terminal, and a
// self-contained HTML page with SVG figures (no scripts, no external files).
#pragma once

#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace quadid::report {

/// A table of already formatted cells. The first column is left-aligned, the
/// others right-aligned (numbers).
struct Table {
  std::string title;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string note;  // printed under the table

  std::string to_text() const;      // aligned columns for a terminal
  std::string to_markdown() const;
  std::string to_html() const;
};

/// One curve of a figure.
struct Series {
  std::string label;
  std::vector<double> x, y;
  std::string color;       // CSS colour; empty = from the palette
  bool dashed = false;
  double width = 1.5;      // stroke width, px
  int layer = 0;           // drawing order: higher layers are drawn later, on top (the legend keeps series order)
};

/// A 2-D line plot. Axis labels must carry units, e.g. "time (s)".
struct Plot {
  std::string title;
  std::string xlabel, ylabel;
  std::vector<Series> series;
  int width = 760, height = 300;  // px
  bool equal_aspect = false;      // same scale on x and y (paths in a plane)
  int max_points = 1500;          // per series; longer series are decimated (min/max kept)
  bool integer_x = false;         // x counts things (flights, runs): ticks at whole numbers only
  /// The y axis's limits when both are finite (curves beyond are clipped at
  /// the frame); otherwise from the data, padded 5 %.
  double y_min = std::numeric_limits<double>::quiet_NaN(), y_max = std::numeric_limits<double>::quiet_NaN();
};

/// Tick labels for evenly spaced ticks `step` apart, as matplotlib's
/// ScalarFormatter labels them: the fewest decimals that tell the ticks apart,
/// a shared power of ten (a multiple of 3) when the numbers are long, and an
/// offset when the ticks differ only far down their digits; `suffix` (e.g.
/// " x10^-3" or " + 0.00268") goes after the axis label. The one labelling of every figure.
struct TickLabels {
  std::vector<std::string> labels;
  std::string suffix;
};
TickLabels tick_labels(const std::vector<double>& ticks, double step);

/// Renders a plot as a standalone <svg> element with axes, ticks, grid, labels and a legend.
std::string render_svg(const Plot& plot);

/// Colours of the paper's figures: Exp black, nominal red, LS blue, GD purple,
/// FMLS green, FMGD orange; other names get distinct palette colours.
std::string color_for(const std::string& set_name, size_t index);

/// Escapes | and \ for a Markdown table cell (and turns newlines into spaces).
std::string markdown_escape(const std::string& s);

/// Escapes &, <, >, " for HTML.
std::string html_escape(const std::string& s);

/// uPlot (npm `uplot`, MIT licence), inlined at build time (cmake/Uplot.cmake):
/// false when the build had no npm; charts then fall back to static SVG.
bool have_uplot();
std::string_view uplot_version();
std::string_view uplot_license();
std::string_view uplot_js();
std::string_view uplot_css();

/// An interactive time series or spectrum: uPlot in the page (drag or the
/// mouse wheel to zoom, shift + drag to pan, double-click to reset, values on
/// hover), one shared x for every series.
/// Axis labels carry units. Log axes need positive values (others are dropped).
struct Chart {
  std::string title;
  std::string xlabel, ylabel;
  std::vector<double> x;
  std::vector<Series> series;  // each y the size of x; label, colour and dash are used
  bool log_x = false, log_y = false;
  int height = 280;       // px; the width follows the page
  int max_points = 4000;  // longer data are decimated (every k-th point)
};

/// A self-contained HTML document built section by section.
class HtmlDocument {
 public:
  explicit HtmlDocument(std::string title);
  void heading(const std::string& text, int level = 2);
  void paragraph(const std::string& text);      // escaped text
  void raw(const std::string& html);            // trusted HTML
  void table(const Table& t);
  void figure(const Plot& p, const std::string& caption = {});
  void figure_row(const std::vector<Plot>& plots, const std::string& caption = {});
  /// An interactive chart (the library inlined once per page), or its SVG plot without uPlot.
  void chart(const Chart& c, const std::string& caption = {});
  std::string str() const;

 private:
  std::string title_;
  std::string body_;
  int figure_count_ = 0;
  int chart_count_ = 0;
};

/// Formats a number for a table: fixed with `digits` decimals; "n/a" when not finite.
std::string fixed(double v, int digits);
/// Significant-digit formatting for parameters of any size (e.g. 0.01537, 1.82246).
std::string sig(double v, int digits = 5);

}  // namespace quadid::report
