#include "quadid/report.hpp"

#include <fmt/format.h>

namespace quadid::report {

HtmlDocument::HtmlDocument(std::string title) : title_(std::move(title)) {}

void HtmlDocument::heading(const std::string& text, int level) {
  body_ += fmt::format("<h{0}>{1}</h{0}>\n", level, html_escape(text));
}
void HtmlDocument::paragraph(const std::string& text) { body_ += "<p>" + html_escape(text) + "</p>\n"; }
void HtmlDocument::raw(const std::string& html) { body_ += html; }
void HtmlDocument::table(const Table& t) { body_ += "<div class=\"tbl\">" + t.to_html() + "</div>\n"; }

void HtmlDocument::figure(const Plot& p, const std::string& caption) { figure_row({p}, caption); }

void HtmlDocument::figure_row(const std::vector<Plot>& plots, const std::string& caption) {
  ++figure_count_;
  body_ += "<figure>\n<div class=\"row\">\n";
  for (const auto& p : plots) body_ += render_svg(p);
  body_ += "</div>\n";
  if (!caption.empty())
    body_ += fmt::format("<figcaption>Figure {}. {}</figcaption>\n", figure_count_, html_escape(caption));
  body_ += "</figure>\n";
}

namespace {
// Opened as page.html#layout-check, the page checks its own SVG figures once
// laid out: a text outside its figure, or two texts that overlap (tick labels
// crowding each other), and writes what it found into <pre id="layout-check">
// ("ok" when nothing): the tests read it from a headless browser's DOM.
constexpr const char* kLayoutCheck = R"(<script>
if (location.hash === "#layout-check") window.addEventListener("load", function () {
  var out = [];
  document.querySelectorAll("svg").forEach(function (svg, si) {
    var r = svg.getBoundingClientRect();
    var axes = svg.querySelectorAll("text.axis-label");
    if (axes.length > 0 && axes.length !== 2) out.push("figure " + si + ": " + axes.length + " axis labels, expected 2");
    axes.forEach(function (t) {
      if (!/\(.+\)/.test(t.textContent)) out.push("figure " + si + ": axis label '" + t.textContent + "' has no unit");
    });
    var ts = Array.prototype.slice.call(svg.querySelectorAll("text"));
    var b = ts.map(function (t) { return t.getBoundingClientRect(); });
    b.forEach(function (a, i) {
      if (a.width === 0) return;
      if (a.left < r.left - 1 || a.right > r.right + 1 || a.top < r.top - 1 || a.bottom > r.bottom + 1)
        out.push("figure " + si + ": '" + ts[i].textContent + "' outside its figure");
      for (var j = i + 1; j < b.length; j++) {
        var c = b[j];
        if (a.left < c.right - 0.5 && c.left < a.right - 0.5 && a.top < c.bottom - 0.5 && c.top < a.bottom - 0.5)
          out.push("figure " + si + ": '" + ts[i].textContent + "' overlaps '" + ts[j].textContent + "'");
      }
    });
  });
  // uPlot draws its ticks on a canvas: each axis's labels (uPlot's own
  // _values at _splits) are measured with the axis's font, and must not
  // overlap their neighbours nor (y) be wider than the axis leaves them; every
  // axis label must carry a unit in brackets.
  var ctx = document.createElement("canvas").getContext("2d");
  (window.quadidCharts || []).forEach(function (u, ci) {
    u.axes.forEach(function (a, ai) {
      if (!a.show) return;
      var name = "chart " + ci + " " + (ai === 0 ? "x" : "y") + " axis";
      if (!/\(.+\)/.test(a.label || "")) out.push(name + ": label '" + (a.label || "") + "' has no unit");
      var vals = a._values || [], sp = a._splits || [], fs = a.font[2], boxes = [];
      ctx.font = a.font[0];
      for (var i = 0; i < vals.length; i++) {
        if (vals[i] == null || vals[i] === "") continue;
        // A label reads as its tick's value (to a thousandth of the tick spacing; of the value on a log axis).
        var num = parseFloat(String(vals[i]).replace(/,/g, "")), inc = sp.length > 1 ? Math.abs(sp[1] - sp[0]) : 1;
        var logax = u.scales[ai === 0 ? "x" : "y"].distr === 3, tol = 1e-3 * (logax ? Math.abs(sp[i]) : inc);
        if (!(Math.abs(num - sp[i]) <= tol)) out.push(name + ": '" + vals[i] + "' labels the tick at " + sp[i]);
        var pos = u.valToPos(sp[i], ai === 0 ? "x" : "y"), w = ctx.measureText(String(vals[i])).width / devicePixelRatio;
        if (ai === 0) boxes.push([pos - w / 2, pos + w / 2, vals[i]]);
        else {
          boxes.push([pos - fs / 2, pos + fs / 2, vals[i]]);
          if (w > a._size - a.ticks.size - a.gap) out.push(name + ": '" + vals[i] + "' wider than its axis");
        }
      }
      boxes.sort(function (x, y) { return x[0] - y[0]; });
      for (var k = 0; k + 1 < boxes.length; k++)
        if (boxes[k][1] > boxes[k + 1][0] + 0.5) out.push(name + ": '" + boxes[k][2] + "' overlaps '" + boxes[k + 1][2] + "'");
    });
  });
  var p = document.createElement("pre");
  p.id = "layout-check";
  p.textContent = out.length ? out.join("\n") : "ok";
  document.body.appendChild(p);
});
</script>
)";

// uPlot zooms by a drag and resets on a double-click; this plugin (every
// chart's) adds the mouse wheel (zoom about the cursor, x) and shift + drag
// (pan, x), on log axes in decades. Each chart keeps its x range apart.
constexpr const char* kZoomPan = R"(function quadidZoomPan() {
  return { hooks: { ready: [function (u) {
    var log = u.scales.x.distr === 3;
    var fw = function (v) { return log ? Math.log10(v) : v; }, bw = function (v) { return log ? Math.pow(10, v) : v; };
    var over = u.over;
    over.addEventListener("wheel", function (e) {
      e.preventDefault();
      var r = over.getBoundingClientRect(), x = (e.clientX - r.left) / r.width;
      var a = fw(u.scales.x.min), b = fw(u.scales.x.max), c = a + x * (b - a), f = e.deltaY < 0 ? 0.8 : 1.25;
      u.setScale("x", { min: bw(c - (c - a) * f), max: bw(c + (b - c) * f) });
    }, { passive: false });
    u.root.addEventListener("mousedown", function (e) {
      if (!e.shiftKey) return;
      e.stopPropagation();  // no selection box: this drag pans
      e.preventDefault();
      var r = over.getBoundingClientRect(), x0 = e.clientX, a = fw(u.scales.x.min), b = fw(u.scales.x.max);
      var move = function (ev) { var d = (ev.clientX - x0) / r.width * (b - a); u.setScale("x", { min: bw(a - d), max: bw(b - d) }); };
      var up = function () { document.removeEventListener("mousemove", move); document.removeEventListener("mouseup", up); };
      document.addEventListener("mousemove", move);
      document.addEventListener("mouseup", up);
    }, true);
  }] } };
})";

// uPlot's styles and script, once in the page's head when it has charts.
std::string chart_head(bool charts) {
  if (!charts || !have_uplot()) return {};
  return fmt::format("<!-- uPlot {} (MIT licence, https://github.com/leeoniya/uPlot):\n{}\n-->\n<style>{}</style>\n<script>{}</script>\n"
                     "<script>{}</script>\n",
                     uplot_version(), uplot_license(), uplot_css(), uplot_js(), kZoomPan);
}
}  // namespace

std::string HtmlDocument::str() const {
  return fmt::format(R"(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{0}</title>
{2}<style>
body {{ font-family: Helvetica, Arial, sans-serif; max-width: 1600px; margin: 2em auto; padding: 0 1.5em; color: #222; line-height: 1.45; }}
h1 {{ font-size: 1.7em; border-bottom: 2px solid #333; padding-bottom: .2em; }}
h2 {{ font-size: 1.35em; margin-top: 2em; border-bottom: 1px solid #bbb; }}
h3 {{ font-size: 1.1em; margin-top: 1.5em; }}
table {{ border-collapse: collapse; margin: .8em 0; font-size: .86em; }}
caption {{ text-align: left; font-weight: bold; padding-bottom: .4em; }}
th, td {{ border: 1px solid #ccc; padding: .25em .35em; }}
td {{ white-space: nowrap; }}
td {{ text-align: right; font-variant-numeric: tabular-nums; }}
thead th {{ background: #f0f0f0; }}
tbody th {{ text-align: left; font-weight: normal; background: #fafafa; }}
td.neg {{ color: #c0392b; }} td.pos {{ color: #1f4fd6; }}
.tbl {{ overflow-x: auto; }}
figure {{ margin: 1.2em 0; }}
figure .row {{ display: flex; flex-wrap: wrap; gap: 8px; }}
figcaption {{ font-size: .92em; color: #444; margin-top: .3em; }}
p.note {{ font-size: .88em; color: #555; margin-top: -.3em; }}
code, pre {{ background: #f5f5f5; padding: 0 .2em; }}
figure.chart {{ max-width: 1400px; }}
.warn {{ border-left: 4px solid #d35400; background: #fff6ef; padding: .3em .8em; margin: .6em 0; }}
.good {{ color: #1e7d32; }} .poor {{ color: #b03a2e; }}
.conclusions {{ border: 2px solid #1f4fd6; background: #f4f7ff; padding: .4em 1.2em; border-radius: 6px; max-width: 1100px; }}
</style>
</head>
<body>
<h1>{0}</h1>
{1}{3}</body>
</html>
)",
                     html_escape(title_), body_, chart_head(chart_count_ > 0), kLayoutCheck);
}

}  // namespace quadid::report
