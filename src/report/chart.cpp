// Interactive charts (HtmlDocument::chart): uPlot inlined in the page, with the
// data as JSON arrays; static SVG (render_svg) where the build has no uPlot.
#include "quadid/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string_view>

namespace quadid::report {
namespace detail {
extern const bool kHaveUplot;
extern const char kUplotVersion[];
std::string_view uplot_js_data();
std::string_view uplot_css_data();
std::string_view uplot_license_data();
}  // namespace detail

bool have_uplot() { return detail::kHaveUplot; }
std::string_view uplot_version() { return detail::kUplotVersion; }
std::string_view uplot_license() { return detail::uplot_license_data(); }
std::string_view uplot_js() { return detail::uplot_js_data(); }
std::string_view uplot_css() { return detail::uplot_css_data(); }

namespace {

// A JSON string literal (the labels), safe inside a <script> element.
std::string js_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '<') {
      o += "\\u003c";
      continue;
    }
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  o += '"';
  return o;
}

// One series' values as a JSON array; null where not finite (or, on a log
// axis, not above `floor`: uPlot's log axis fails on a range of hundreds of decades).
std::string js_array(const std::vector<double>& v, size_t step, bool positive, double floor = 0.0) {
  std::string o = "[";
  for (size_t i = 0; i < v.size(); i += step) {
    if (i) o += ',';
    const double x = v[i];
    o += std::isfinite(x) && (!positive || x > floor) ? fmt::format("{:.7g}", x) : "null";
  }
  o += ']';
  return o;
}

// uPlot's tick labels on a linear axis, as tick_labels does for the SVG figures:
// the fewest decimals that write the tick increment exactly (2.5 s steps: one;
// 0 decimals printed 2.5, 7.5 as "3", "8"), and
// a power of ten for long numbers (0.0120, 0.0122, ... not 0.012, 0.012, ...).
constexpr const char* kTickValues =
    ",values:function(u,s){var inc=s.length>1?Math.abs(s[1]-s[0]):1;var big=0;"
    "s.forEach(function(v){if(v!=null)big=Math.max(big,Math.abs(v));});"
    "var d=0;while(d<12&&Math.abs(inc*Math.pow(10,d)-Math.round(inc*Math.pow(10,d)))>1e-6*inc*Math.pow(10,d))d++;"
    "var sci=big>=1e4||(big>0&&big<1e-2);"
    "var sd=Math.max(0,Math.min(8,Math.floor(Math.log10(big||1))-Math.floor(Math.log10(inc)+1e-9)));"
    "return s.map(function(v){if(v==null)return '';if(Math.abs(v)<inc*1e-9)v=0;"
    "return sci?(v===0?'0':v.toExponential(sd)):v.toFixed(Math.min(d,12));});}";

// ... and on a log axis, the values themselves: plain from 0.001 to 1e4, else
// as "2.5e-11" (uPlot's default wrote every tick below 0.001 as "0").
constexpr const char* kLogTickValues =
    ",values:function(u,s){return s.map(function(v){if(v==null)return '';var a=Math.abs(v);"
    "if(a>=1e-3&&a<1e4)return String(+v.toPrecision(3));"
    "return v.toExponential(2).replace(/\\.?0+e/,'e').replace('e+','e');});}";

Plot as_plot(const Chart& c) {
  Plot p;
  p.title = c.title;
  p.xlabel = c.xlabel;
  p.ylabel = c.ylabel;
  for (const auto& s : c.series) {
    Series t = s;
    t.x = c.x;
    p.series.push_back(std::move(t));
  }
  p.width = 1200;
  p.height = c.height;
  return p;
}

}  // namespace

void HtmlDocument::chart(const Chart& c, const std::string& caption) {
  if (!have_uplot()) {
    figure(as_plot(c), caption);
    return;
  }
  // uPlot's log axis breaks on values far from 1 (below ~1e-16 it throws
  // "Invalid array length": a 30 g vehicle's torque spectra). Beyond 1e+-6
  // the chart shows the values in units of 10^k, which its y label then says.
  if (c.log_y) {
    double top = 0.0;
    for (const auto& s : c.series)
      for (double y : s.y)
        if (std::isfinite(y)) top = std::max(top, y);
    if (top > 0.0 && std::abs(std::floor(std::log10(top))) > 6) {
      const double k = std::floor(std::log10(top)), f = std::pow(10.0, -k);
      Chart shown = c;
      for (auto& s : shown.series)
        for (double& y : s.y) y *= f;
      shown.ylabel += fmt::format(" x1e{:g}", k);
      chart(shown, caption);
      return;
    }
  }
  ++figure_count_;
  const int id = ++chart_count_;
  const size_t step = std::max<size_t>(1, (c.x.size() + static_cast<size_t>(c.max_points) - 1) /
                                              static_cast<size_t>(std::max(1, c.max_points)));
  // A log y axis shows 12 decades below the largest value at most.
  double top = 0.0;
  for (const auto& s : c.series)
    for (double y : s.y)
      if (std::isfinite(y)) top = std::max(top, y);
  const double floor = c.log_y ? top * 1e-12 : 0.0;
  std::string data = "[";
  data += js_array(c.x, step, c.log_x);
  std::string series = fmt::format("[{{label:{}}}", js_string(c.xlabel));
  for (size_t i = 0; i < c.series.size(); ++i) {
    const Series& s = c.series[i];
    data += ',';
    data += js_array(s.y, step, c.log_y, floor);
    series += fmt::format(",{{label:{},stroke:{},width:{:g}{}}}", js_string(s.label),
                          js_string(s.color.empty() ? color_for(s.label, i) : s.color), s.width,
                          s.dashed ? ",dash:[6,4]" : "");
  }
  data += "]";
  series += "]";
  // A log x scale keeps the range it is given (uPlot would snap a zoom or a
  // pan to whole decades); every chart is kept in window.quadidCharts for the
  // page's layout check.
  body_ += fmt::format(
      "<figure class=\"chart\"><div id=\"chart{0}\" class=\"chart-box\" data-title={1}></div>\n"
      "<script>(function(){{var el=document.getElementById(\"chart{0}\");"
      "var w=Math.max(480,Math.min(1400,el.parentNode.clientWidth||1200));"
      "(window.quadidCharts=window.quadidCharts||[]).push(new uPlot({{title:{1},width:w,height:{2},scales:{{x:{{time:false{3}}},y:{{{4}}}}},"
      "axes:[{{label:{5}{9}}},{{label:{6},size:80{10}}}],series:{7},plugins:[quadidZoomPan()],cursor:{{drag:{{x:true,y:false}}}}}},{8},el));}})();</script>\n",
      id, js_string(c.title), c.height, c.log_x ? ",distr:3,range:function(u,a,b){return [a,b];}" : "", c.log_y ? "distr:3" : "", js_string(c.xlabel),
      js_string(c.ylabel), series, data, c.log_x ? kLogTickValues : kTickValues, c.log_y ? kLogTickValues : kTickValues);
  if (!caption.empty())
    body_ += fmt::format("<figcaption>Figure {}. {}</figcaption>\n", figure_count_, html_escape(caption));
  body_ += "</figure>\n";
}

}  // namespace quadid::report
