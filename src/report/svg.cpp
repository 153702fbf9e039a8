// SVG line plots: axes with "nice" ticks, grid, labels with units, and a legend
// below the plot area so that six curves stay readable.
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace quadid::report {

namespace {

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (std::isfinite(v)) { lo = std::min(lo, v); hi = std::max(hi, v); }
  }
  bool valid() const { return lo <= hi; }
};

// Tick step from {1, 2, 5} x 10^k giving about `target` intervals.
double nice_step(double span, int target) {
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nf = f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0;
  return nf * mag;
}

void widen(Range& r) {
  if (!r.valid()) { r.lo = 0; r.hi = 1; return; }
  if (r.hi - r.lo < 1e-12 * std::max(1.0, std::abs(r.hi))) {
    const double d = std::max(1e-3, std::abs(r.hi) * 0.05);
    r.lo -= d;
    r.hi += d;
  }
}

// Keeps the first, last, min and max of each bucket, so peaks survive decimation.
std::vector<std::pair<double, double>> decimate(const Series& s, int max_points) {
  const size_t n = std::min(s.x.size(), s.y.size());
  std::vector<std::pair<double, double>> out;
  if (n <= static_cast<size_t>(max_points)) {
    for (size_t i = 0; i < n; ++i) out.emplace_back(s.x[i], s.y[i]);
    return out;
  }
  const size_t buckets = static_cast<size_t>(std::max(1, max_points / 2));
  for (size_t b = 0; b < buckets; ++b) {
    const size_t i0 = b * n / buckets, i1 = (b + 1) * n / buckets;
    size_t imin = i0, imax = i0;
    for (size_t i = i0; i < i1; ++i) {
      if (s.y[i] < s.y[imin]) imin = i;
      if (s.y[i] > s.y[imax]) imax = i;
    }
    const size_t a = std::min(imin, imax), c = std::max(imin, imax);
    out.emplace_back(s.x[a], s.y[a]);
    if (c != a) out.emplace_back(s.x[c], s.y[c]);
  }
  return out;
}

}  // namespace

TickLabels tick_labels(const std::vector<double>& ticks, double step) {
  TickLabels out;
  if (ticks.empty() || !(step > 0.0)) return out;
  double big = 0.0;
  for (double t : ticks) big = std::max(big, std::abs(t));
  // An offset when the ticks differ only far down their digits (0.002688, 0.002690, ...):
  // the labels then count from the first tick, rounded to ten steps.
  double offset = 0.0;
  if (big > 0.0 && step / big < 1e-3) {
    offset = std::floor(ticks.front() / (10.0 * step)) * 10.0 * step;
    big = 0.0;
    for (double t : ticks) big = std::max(big, std::abs(t - offset));
  }
  // A shared power of ten, a multiple of 3, when the labels would be long.
  int e = 0;
  if (big >= 1e4 || (big > 0.0 && big < 1e-2)) e = 3 * static_cast<int>(std::floor(std::log10(big) / 3.0));
  const double scale = std::pow(10.0, -e);
  const int dec = std::max(0, -static_cast<int>(std::floor(std::log10(step * scale) + 1e-9)));
  for (double t : ticks) {
    double v = (t - offset) * scale;
    if (std::abs(v) < step * scale * 1e-9) v = 0.0;  // no "-0.0"
    out.labels.push_back(fmt::format("{:.{}f}", v, dec));
  }
  if (e != 0) out.suffix += fmt::format(" \u00d710^{}", e);
  if (offset != 0.0) out.suffix += fmt::format(" {} {}", offset > 0 ? "+" : "-", fmt::format("{:.6g}", std::abs(offset)));
  return out;
}

std::string color_for(const std::string& name, size_t index) {
  if (name == "Exp" || name == "experiment" || name == "true" || name == "log") return "#000000";
  if (name == "nominal" || name == "nom") return "#d62728";
  if (name == "LS") return "#1f4fd6";
  if (name == "GD") return "#8e44ad";
  if (name == "FMLS") return "#2ca02c";
  if (name == "FMGD") return "#ff7f0e";
  static const char* palette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                  "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return palette[index % 10];
}

namespace {
// The multiples of `step` inside r.
std::vector<double> ticks(const Range& r, double step) {
  std::vector<double> t;
  for (double v = std::ceil(r.lo / step) * step; v <= r.hi + 1e-9 * step; v += step) t.push_back(v);
  return t;
}
}  // namespace

namespace {
// The grid lines at the ticks and the tick labels of both axes.
template <class FX, class FY>
std::string grid_and_tick_labels(const std::vector<double>& xt, const std::vector<double>& yt, const TickLabels& xl,
                                 const TickLabels& yl, const FX& X, const FY& Y, double ml, double mt, double pw,
                                 double ph) {
  std::string o = "<g stroke=\"#e3e3e3\" stroke-width=\"1\">\n";
  for (double t : xt)
    o += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\"/>\n", X(t), mt, mt + ph);
  for (double t : yt)
    o += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\"/>\n", ml, Y(t), ml + pw);
  o += "</g>\n<g fill=\"#333\">\n";
  for (size_t i = 0; i < xt.size(); ++i)
    o += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n", X(xt[i]), mt + ph + 15,
                     xl.labels[i]);
  for (size_t i = 0; i < yt.size(); ++i)
    o += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n", ml - 6, Y(yt[i]) + 4,
                     yl.labels[i]);
  return o + "</g>\n";
}
}  // namespace

namespace {
// Where everything goes for a left margin `ml`: the legend's rows, the plot
// area and both axes' ranges, and the y ticks with their labels.
struct Layout {
  double ml = 0, mr = 20, mt = 0, mb = 0, pw = 0, ph = 0;
  std::vector<std::pair<double, size_t>> legend_pos;  // x offset, row
  size_t legend_rows = 0;
  Range xr, yr;
  double ys = 0;
  std::vector<double> yt;
  TickLabels yl;
};

Layout layout(const Plot& plot, double ml) {
  Layout L;
  const double W = plot.width, H = plot.height;
  L.ml = ml;
  L.mt = plot.title.empty() ? 14 : 30;
  // Legend rows below the x label: entries as wide as their labels, as many
  // per row as fit (a sample line of 24 px, 6 px gap, ~6.5 px per character at 12 px).
  const size_t nser = plot.series.size();
  const double legend_w = W - L.ml - L.mr;
  L.legend_pos.resize(nser);
  if (nser > 1) {
    double x = 0.0;
    L.legend_rows = 1;
    for (size_t k = 0; k < nser; ++k) {
      const double w = 24 + 6 + 6.5 * static_cast<double>(plot.series[k].label.size()) + 14;
      if (x > 0.0 && x + w > legend_w) {
        x = 0.0;
        ++L.legend_rows;
      }
      L.legend_pos[k] = {x, L.legend_rows - 1};
      x += w;
    }
  }
  L.mb = 48 + 18.0 * static_cast<double>(L.legend_rows);
  L.pw = W - L.ml - L.mr;
  L.ph = H - L.mt - L.mb;
  Range& xr = L.xr;
  Range& yr = L.yr;
  for (const auto& s : plot.series) {
    for (double v : s.x) xr.add(v);
    for (double v : s.y) yr.add(v);
  }
  widen(xr);
  widen(yr);
  if (plot.equal_aspect) {
    // Same metres per pixel on both axes, centred.
    const double sx = (xr.hi - xr.lo) / L.pw, sy = (yr.hi - yr.lo) / L.ph, sc = std::max(sx, sy) * 1.05;
    const double cx = 0.5 * (xr.lo + xr.hi), cy = 0.5 * (yr.lo + yr.hi);
    xr = {cx - 0.5 * sc * L.pw, cx + 0.5 * sc * L.pw};
    yr = {cy - 0.5 * sc * L.ph, cy + 0.5 * sc * L.ph};
  } else if (std::isfinite(plot.y_min) && std::isfinite(plot.y_max) && plot.y_max > plot.y_min) {
    yr = {plot.y_min, plot.y_max};
  } else {
    const double pad = 0.05 * (yr.hi - yr.lo);
    yr.lo -= pad;
    yr.hi += pad;
  }
  L.ys = nice_step(yr.hi - yr.lo, 5);
  L.yt = ticks(yr, L.ys);
  L.yl = tick_labels(L.yt, L.ys);
  return L;
}
}  // namespace

std::string render_svg(const Plot& plot) {
  const double W = plot.width, H = plot.height;
  // The left margin holds the y tick labels (right-aligned 6 px from the axis,
  // ~7 px a digit at 12 px) clear of the rotated y label (x 7-22 px).
  Layout L = layout(plot, 70);
  size_t longest_y = 0;
  for (const auto& l : L.yl.labels) longest_y = std::max(longest_y, l.size());
  if (const double need = 30.0 + 7.0 * static_cast<double>(longest_y); need > 70) L = layout(plot, need);
  const double ml = L.ml, mt = L.mt, pw = L.pw, ph = L.ph;
  const Range xr = L.xr, yr = L.yr;
  const size_t nser = plot.series.size();
  const auto& legend_pos = L.legend_pos;
  auto X = [&](double x) { return ml + (x - xr.lo) / (xr.hi - xr.lo) * pw; };
  auto Y = [&](double y) { return mt + (yr.hi - y) / (yr.hi - yr.lo) * ph; };

  std::string o = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\" role=\"img\" aria-label=\"{2}\">\n",
      W, H, html_escape(plot.title.empty() ? plot.ylabel : plot.title));
  o += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n", W, H);
  if (!plot.title.empty())
    o += fmt::format("<text x=\"{}\" y=\"19\" text-anchor=\"middle\" font-size=\"14\" font-weight=\"bold\">{}</text>\n",
                     ml + pw / 2, html_escape(plot.title));
  // Grid and ticks: one labelling (tick_labels) for both axes, its shared
  // offset and exponent written after the axis label.
  // x ticks: about 8, fewer when their labels (~7 px a character at 12 px, and a gap) would touch.
  const auto x_step = [&](int target) {
    const double st = nice_step(xr.hi - xr.lo, target);
    return plot.integer_x ? std::max(st, 1.0) : st;
  };
  double xs = x_step(8);
  std::vector<double> xt = ticks(xr, xs);
  TickLabels xl = tick_labels(xt, xs);
  for (int target = 7; target >= 2; --target) {
    size_t longest = 0;
    for (const auto& l : xl.labels) longest = std::max(longest, l.size());
    if (xt.size() < 2 || pw / static_cast<double>(xt.size()) >= 7.0 * static_cast<double>(longest) + 12.0) break;
    xs = x_step(target);
    xt = ticks(xr, xs);
    xl = tick_labels(xt, xs);
  }
  o += grid_and_tick_labels(xt, L.yt, xl, L.yl, X, Y, ml, mt, pw, ph);
  o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#555\"/>\n", ml, mt, pw, ph);
  o += fmt::format("<text class=\"axis-label\" x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n", ml + pw / 2,
                   mt + ph + 33, html_escape(plot.xlabel + xl.suffix));
  o += fmt::format("<text class=\"axis-label\" transform=\"translate(16,{:.1f}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
                   mt + ph / 2, html_escape(plot.ylabel + L.yl.suffix));
  // Curves, clipped to the plot area.
  static int clip_counter = 0;
  const int clip_id = ++clip_counter;
  o += fmt::format("<clipPath id=\"c{}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n", clip_id,
                   ml, mt, pw, ph);
  o += fmt::format("<g clip-path=\"url(#c{})\" fill=\"none\" stroke-linejoin=\"round\">\n", clip_id);
  std::vector<size_t> order(nser);
  for (size_t k = 0; k < nser; ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return plot.series[a].layer < plot.series[b].layer; });
  for (const size_t k : order) {
    const auto& s = plot.series[k];
    const std::string col = s.color.empty() ? color_for(s.label, k) : s.color;
    std::string d;
    bool pen_up = true;
    for (const auto& [x, y] : decimate(s, plot.max_points)) {
      if (!std::isfinite(x) || !std::isfinite(y)) { pen_up = true; continue; }
      d += fmt::format("{}{:.1f},{:.1f}", pen_up ? "M" : "L", X(x), Y(y));
      pen_up = false;
    }
    o += fmt::format("<path d=\"{}\" stroke=\"{}\" stroke-width=\"{}\"{}/>\n", d, col, s.width,
                     s.dashed ? " stroke-dasharray=\"6,3\"" : "");
  }
  o += "</g>\n";
  // Legend.
  if (nser > 1) {
    o += "<g>\n";
    for (size_t k = 0; k < nser; ++k) {
      const auto& s = plot.series[k];
      const double lx = ml + legend_pos[k].first;
      const double ly = mt + ph + 50 + 18.0 * static_cast<double>(legend_pos[k].second);
      const std::string col = s.color.empty() ? color_for(s.label, k) : s.color;
      o += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" stroke-width=\"{}\"{}/>",
                       lx, ly - 4, lx + 24, ly - 4, col, std::max(2.0, s.width), s.dashed ? " stroke-dasharray=\"6,3\"" : "");
      o += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n", lx + 30, ly, html_escape(s.label));
    }
    o += "</g>\n";
  }
  o += "</svg>\n";
  return o;
}

}  // namespace quadid::report
