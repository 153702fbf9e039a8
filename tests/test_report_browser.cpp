// The reproduction report renders in a real browser: headless Chromium (Debian's
// `chromium` package) loads report.html, and the DOM it built holds every
// figure and table. Skipped where Chromium is not installed.
#include "cli_fixture.hpp"
#include "quadid/report.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <regex>

using quadid::testing::CliRun;
using quadid::testing::CliTest;

namespace {

const char* chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (std::filesystem::exists(p)) return p;
  return nullptr;
}

size_t count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t i = s.find(what); i != std::string::npos; i = s.find(what, i + 1)) ++n;
  return n;
}

// Headless Chromium as every test here starts it: no network (this machine's
// closed network refuses Chromium's background connections), a fresh profile,
// a window of `size` ("W,H"), then `extra` flags; ends with a space.
std::string chrome_flags(const std::string& profile, const std::string& size, const std::string& extra = "") {
  return "--headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking "
         "--disable-component-update --disable-sync " + (extra.empty() ? "" : extra + " ") + "--user-data-dir=" +
         profile + " --window-size=" + size + " ";
}

// What the page's #layout-check found (HtmlDocument's self-check), for a failure message.
std::string layout_findings(const std::string& dom) {
  const auto a = dom.find("<pre id=\"layout-check\">");
  if (a == std::string::npos) return "no layout-check result in the page";
  return dom.substr(a, std::min<size_t>(2000, dom.find("</pre>", a) - a));
}

}  // namespace

class ReportBrowser : public CliTest {};

// The Monte Carlo page's histograms (seven SVG figures, 520 px wide): their tick labels
// used to crowd each other ("0.0026880.002690...", 12 overlaps on the mass axis).
TEST_F(ReportBrowser, MonteCarloHistogramsHaveNoOverlappingLabels) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  const CliRun r = run("montecarlo --runs 12 --duration 20 --out " + path("mc") + " -q");
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string flags = chrome_flags(path("profile"), "1600,4000");
  std::system((std::string(chrome) + " " + flags + "--dump-dom file://" + path("mc/index.html") + "#layout-check > " +
               path("layout.html") + " 2>/dev/null").c_str());
  const std::string dom = quadid::read_file(path("layout.html"));
  EXPECT_EQ(count(dom, "<svg"), 7u);
  EXPECT_NE(dom.find("<pre id=\"layout-check\">ok</pre>"), std::string::npos) << layout_findings(dom);
}

TEST_F(ReportBrowser, ChromiumRendersEveryFigureAndTable) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  const CliRun r = run("reproduce --trajectory table2 --duration 20 --out " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  // The flags keep Chromium off the network (this machine has none) and out of the user's profile.
  const std::string flags = chrome_flags(path("profile"), "1600,4000");
  const std::string url = "file://" + path("rep/report.html");
  const std::string dom_file = path("dom.html"), png = path("report.png");
  std::system((std::string(chrome) + " " + flags + "--dump-dom " + url + " > " + dom_file + " 2>/dev/null").c_str());
  std::system((std::string(chrome) + " " + flags + "--screenshot=" + png + " " + url + " > /dev/null 2>&1").c_str());
  const std::string dom = quadid::read_file(dom_file);
  // 14 captions; 2 + 2 + 6 + 6 + 2 + 2 + 1 + 3 + 3 + 3 + 3 + 2 + 2 + 3 = 40 plots (trajectory, mass,
  // moments and products each as least squares beside gradient descent, one row per parameter, LS residuals and their spectra (force and moment rows apart), path, position
  // and its differences, attitude and its differences, inputs in two rows of two, circle paths; see
  // reproduction_html).
  EXPECT_EQ(count(dom, "<svg"), 40u);
  EXPECT_EQ(count(dom, "<figcaption>"), 14u);
  // Table 2, the constraint check, Table 3 and its errors, Tables 4 to 12, and the conclusions; and
  // in section 2 as tables, not text: LS's and FMLS's intervals, the physical checks, the recommended set.
  EXPECT_EQ(count(dom, "<table>"), 18u);
  EXPECT_EQ(dom.find("<pre"), std::string::npos);  // no terminal text dumped in the page
  EXPECT_NE(dom.find("time (s)"), std::string::npos);
  // Laid out as a person sees it: no tick labels crowding each other, no text outside its figure.
  std::system((std::string(chrome) + " " + flags + "--dump-dom " + url + "#layout-check > " + path("layout.html") +
               " 2>/dev/null").c_str());
  EXPECT_NE(quadid::read_file(path("layout.html")).find("<pre id=\"layout-check\">ok</pre>"), std::string::npos)
      << layout_findings(quadid::read_file(path("layout.html")));
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_GT(std::filesystem::file_size(png), 100000u);  // a blank 1600x4000 page compresses to a few kB
}

// identify --report: one page, every chart drawn by uPlot without a console error, and the
// recommended set's numbers those of the result JSON (issue 42).
TEST_F(ReportBrowser, IdentifyReportRendersItsChartsAndShowsTheResultsNumbers) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  ASSERT_EQ(run("simulate --trajectory table2 --duration 30 --seed 2 -o " + path("f.csv")).rc, 0);
  const CliRun r = run("identify " + path("f.csv") + " --window 2:28 -q -o " + path("r.json") + " --report " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string page = quadid::read_file(path("rep/report.html"));
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);  // one file: nothing fetched
  const std::string flags = chrome_flags(path("profile"), "1400,6000", "--enable-logging=stderr --v=0");
  const std::string url = "file://" + path("rep/report.html");
  std::system((std::string(chrome) + " " + flags + "--dump-dom " + url + " > " + path("dom.html") + " 2> " +
               path("console.txt")).c_str());
  const std::string dom = quadid::read_file(path("dom.html")), console = quadid::read_file(path("console.txt"));
  EXPECT_EQ(console.find("Uncaught"), std::string::npos) << console;
  // 4 axes x (time series + spectrum), each a uPlot chart with a canvas (static SVG in a build without uPlot).
  if (quadid::report::have_uplot()) {
    EXPECT_EQ(count(dom, "class=\"uplot"), 8u);
    EXPECT_EQ(count(dom, "<canvas"), 8u);
  } else {
    EXPECT_EQ(count(dom, "<svg"), 8u);
  }
  // The recommended set's values, as the page holds them (data-value, full precision), equal the JSON's.
  const auto j = nlohmann::ordered_json::parse(quadid::read_file(path("r.json")));
  const std::string set = j["recommended"]["set"].get<std::string>();
  const std::regex cell("<tr><th>([A-Za-z]+)</th><td data-value=\"([^\"]+)\"");
  int matched = 0;
  for (auto it = std::sregex_iterator(page.begin(), page.end(), cell); it != std::sregex_iterator(); ++it) {
    const std::string name = (*it)[1];
    EXPECT_EQ(std::stod((*it)[2]), j["estimates"][set][name].get<double>()) << name;
    ++matched;
  }
  EXPECT_EQ(matched, 7);
  // The sensitivity table: four cutoffs and the two halves of the window, each with its numbers.
  const auto sens = page.find("id=\"sensitivity\"");
  ASSERT_NE(sens, std::string::npos);
  EXPECT_EQ(count(page.substr(sens, page.find("id=\"log\"") - sens), " se)"), 6u * 4u);
  // Every chart's axes carry a unit.
  for (const char* label : {"time (s)", "frequency (Hz)", "Fz (N)", "tau_phi (N m)", "PSD ((N m)^2/Hz)"})
    EXPECT_NE(page.find(label), std::string::npos) << label;
  // The rendered charts: no canvas tick label overlaps its neighbour or is wider than its axis, every axis has a unit.
  std::system((std::string(chrome) + " " + flags + "--dump-dom '" + url + "#layout-check' > " + path("layout.html") +
               " 2>/dev/null").c_str());
  const std::string laid = quadid::read_file(path("layout.html"));
  EXPECT_NE(laid.find("<pre id=\"layout-check\">ok</pre>"), std::string::npos) << layout_findings(laid);
}

// The layout check of the canvas charts is real: a chart whose y axis has no
// unit, and one whose tick labels are too wide for its axis (squeezed to 30 px),
// are named; the same chart done right passes.
TEST_F(ReportBrowser, LayoutCheckNamesAUnitlessAxisAndCrowdedCanvasTicks) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  if (!quadid::report::have_uplot()) GTEST_SKIP() << "this build has no uPlot (no npm at configure time)";
  const auto page = [](const std::string& ylabel, double offset) {
    quadid::report::HtmlDocument doc("check");
    quadid::report::Chart c;
    c.title = "a chart";
    c.xlabel = "time (s)";
    c.ylabel = ylabel;
    for (int i = 0; i < 200; ++i) c.x.push_back(0.01 * i);
    quadid::report::Series s;
    s.label = "y";
    for (double x : c.x) s.y.push_back(offset + 1e-9 * std::sin(20 * x));
    c.series.push_back(s);
    doc.chart(c);
    return doc.str();
  };
  const std::string flags = chrome_flags(path("profile"), "1000,800");
  const auto check = [&](const std::string& html) {
    write("p.html", html);
    std::system((std::string(chrome) + " " + flags + "--dump-dom 'file://" + path("p.html") + "#layout-check' > " +
                 path("dom.html") + " 2>/dev/null").c_str());
    return layout_findings(quadid::read_file(path("dom.html")));
  };
  EXPECT_NE(check(page("force", 0.0)).find("chart 0 y axis: label 'force' has no unit"), std::string::npos);
  std::string narrow = page("force (N)", 0.0);  // the y axis squeezed to 30 px: labels like "-5.0e-10" no longer fit
  ASSERT_NE(narrow.find("size:80"), std::string::npos);
  narrow.replace(narrow.find("size:80"), 7, "size:30");
  const std::string crowded = check(narrow);
  EXPECT_NE(crowded.find("wider than its axis"), std::string::npos) << crowded;
  EXPECT_EQ(check(page("force (N)", 0.0)), "<pre id=\"layout-check\">ok");
}

// follow --report: the segments' table and the tracking estimate's four charts, no console error.
TEST_F(ReportBrowser, FollowReportRendersTheTrackingCharts) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  ASSERT_EQ(run("simulate --trajectory table2 --duration 20 --payload-change 10:0.2 -o " + path("f.csv")).rc, 0);
  const CliRun r = run("follow " + path("f.csv") + " -q --json --report " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string flags = chrome_flags(path("profile"), "1300,2000", "--enable-logging=stderr --v=0");
  std::system((std::string(chrome) + " " + flags + "--dump-dom file://" + path("rep/report.html") + " > " +
               path("dom.html") + " 2> " + path("console.txt")).c_str());
  const std::string dom = quadid::read_file(path("dom.html")), console = quadid::read_file(path("console.txt"));
  EXPECT_EQ(console.find("Uncaught"), std::string::npos) << console;
  EXPECT_EQ(count(dom, quadid::report::have_uplot() ? "<canvas" : "<svg"), 4u);
  const auto j = nlohmann::ordered_json::parse(r.out);
  ASSERT_EQ(j["changes"].size(), 1u);
  EXPECT_NE(dom.find(fmt::format("At {:.2f} s", j["changes"][0]["t"].get<double>())), std::string::npos);
  std::system((std::string(chrome) + " " + flags + "--dump-dom 'file://" + path("rep/report.html") + "#layout-check' > " +
               path("layout.html") + " 2>/dev/null").c_str());
  const std::string laid = quadid::read_file(path("layout.html"));
  EXPECT_NE(laid.find("<pre id=\"layout-check\">ok</pre>"), std::string::npos) << layout_findings(laid);
}

// batch --report: the fleet page (a figure per parameter, the logs with links)
// renders with no console error and passes its own layout check; each log's
// own page does too.
TEST_F(ReportBrowser, FleetReportRendersAndLinksEachLogsPage) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  std::string logs;
  for (int seed : {1, 2, 3}) {
    const std::string f = path(fmt::format("f{}.csv", seed));
    ASSERT_EQ(run(fmt::format("simulate --trajectory table2 --duration 12 --seed {} -o {}", seed, f)).rc, 0);
    logs += " " + f;
  }
  const CliRun r = run("batch -q --window 2:10 --report " + path("fleet") + logs + " -o " + path("out.jsonl"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string flags = chrome_flags(path("profile"), "1400,2400", "--enable-logging=stderr --v=0");
  for (const std::string page : {"fleet/index.html", "fleet/flights/002-f2.html"}) {
    std::system((std::string(chrome) + " " + flags + "--dump-dom 'file://" + path(page) + "#layout-check' > " +
                 path("dom.html") + " 2> " + path("console.txt")).c_str());
    const std::string dom = quadid::read_file(path("dom.html")), console = quadid::read_file(path("console.txt"));
    EXPECT_EQ(console.find("Uncaught"), std::string::npos) << page << console;
    EXPECT_NE(dom.find("<pre id=\"layout-check\">ok</pre>"), std::string::npos) << page << layout_findings(dom);
    if (page == "fleet/index.html") {
      EXPECT_EQ(count(dom, "<svg"), 7u);  // one figure per parameter that varies over the flights
      EXPECT_EQ(count(dom, "href=\"flights/"), 3u);
    }
  }
}

// The charts zoom with the mouse wheel about the cursor and pan with shift +
// drag, on a linear and on a log x axis: events dispatched in the page move
// the x range as they should (zoom in by 0.8 about the cursor; a pan by a
// quarter of the width shifts the range by a quarter of its span, in decades
// on the log axis). Tolerance 1e-6 of the span: the events' pixel positions
// are whole pixels, which the expected values are computed from.
TEST_F(ReportBrowser, ChartsZoomWithTheWheelAndPanWithShiftDrag) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  if (!quadid::report::have_uplot()) GTEST_SKIP() << "this build has no uPlot (no npm at configure time)";
  quadid::report::HtmlDocument doc("zoom");
  for (bool log_x : {false, true}) {
    quadid::report::Chart c;
    c.title = log_x ? "spectrum" : "series";
    c.xlabel = log_x ? "frequency (Hz)" : "time (s)";
    c.ylabel = "y (N)";
    c.log_x = log_x;
    for (int i = 1; i <= 1000; ++i) c.x.push_back(log_x ? std::pow(10.0, -1.0 + 3.0 * i / 1000.0) : 0.01 * i);
    quadid::report::Series s;
    s.label = "y";
    for (double x : c.x) s.y.push_back(std::sin(x));
    c.series.push_back(s);
    doc.chart(c);
  }
  // For each chart: the range, then after a wheel step in at the middle, then after a shift-drag by a quarter width.
  // uPlot applies a new scale in a microtask (and snapped a log x range to whole decades: none since): each step waits a timer before reading it.
  doc.raw(R"(<script>window.addEventListener("load", async function () {
  var out = [], later = function () { return new Promise(function (r) { setTimeout(r, 20); }); };
  for (const u of window.quadidCharts) {
    var log = u.scales.x.distr === 3, f = function (v) { return log ? Math.log10(v) : v; };
    var r = u.over.getBoundingClientRect(), cx = Math.round(r.left + r.width / 2), cy = Math.round(r.top + r.height / 2);
    var a0 = f(u.scales.x.min), b0 = f(u.scales.x.max), c = a0 + (cx - r.left) / r.width * (b0 - a0);
    u.over.dispatchEvent(new WheelEvent("wheel", {deltaY: -100, clientX: cx, clientY: cy, bubbles: true, cancelable: true}));
    await later();
    var a1 = f(u.scales.x.min), b1 = f(u.scales.x.max);
    var zoom_ok = Math.abs(a1 - (c - (c - a0) * 0.8)) < 1e-6 * (b0 - a0) && Math.abs(b1 - (c + (b0 - c) * 0.8)) < 1e-6 * (b0 - a0);
    var dx = Math.round(r.width / 4), opts = {clientX: cx, clientY: cy, shiftKey: true, bubbles: true, cancelable: true};
    u.over.dispatchEvent(new MouseEvent("mousedown", opts));
    opts.clientX = cx + dx;
    document.dispatchEvent(new MouseEvent("mousemove", opts));
    document.dispatchEvent(new MouseEvent("mouseup", opts));
    await later();
    var d = dx / r.width * (b1 - a1), a2 = f(u.scales.x.min), b2 = f(u.scales.x.max);
    var pan_ok = Math.abs(a2 - (a1 - d)) < 1e-6 * (b0 - a0) && Math.abs(b2 - (b1 - d)) < 1e-6 * (b0 - a0);
    out.push((log ? "log" : "linear") + " zoom " + (zoom_ok ? "ok" : "bad " + [a0, b0, a1, b1]) + " pan " +
             (pan_ok ? "ok" : "bad " + [a1, b1, a2, b2]));
  }
  var p = document.createElement("pre"); p.id = "zoom-check"; p.textContent = out.join("\n"); document.body.appendChild(p);
});</script>)");
  write("zoom.html", doc.str());
  const std::string flags = chrome_flags(path("profile"), "1200,900", "--virtual-time-budget=5000");
  std::system((std::string(chrome) + " " + flags + "--dump-dom file://" + path("zoom.html") + " > " + path("dom.html") +
               " 2>/dev/null").c_str());
  const std::string dom = quadid::read_file(path("dom.html"));
  const auto a = dom.find("<pre id=\"zoom-check\">");
  ASSERT_NE(a, std::string::npos) << dom.substr(0, 500);
  EXPECT_EQ(dom.substr(a, dom.find("</pre>", a) - a), "<pre id=\"zoom-check\">linear zoom ok pan ok\nlog zoom ok pan ok");
}

// A 30 g vehicle's torque spectra lie near 1e-20 (N m)^2/Hz, where uPlot's log
// axis threw "Invalid array length" and drew nothing: its page renders all
// eight charts, with no console error, every tick label reading as its value.
TEST_F(ReportBrowser, ASmallVehiclesSpectraRender) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  ASSERT_EQ(run("simulate --vehicle crazyflie21 --trajectory circle1 --duration 20 -o " + path("cf.csv")).rc, 0);
  const CliRun r = run("identify " + path("cf.csv") + " --vehicle crazyflie21 -q --report " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string flags = chrome_flags(path("profile"), "1400,6000", "--enable-logging=stderr --v=0");
  std::system((std::string(chrome) + " " + flags + "--dump-dom 'file://" + path("rep/report.html") + "#layout-check' > " +
               path("dom.html") + " 2> " + path("console.txt")).c_str());
  const std::string dom = quadid::read_file(path("dom.html")), console = quadid::read_file(path("console.txt"));
  EXPECT_EQ(console.find("Uncaught"), std::string::npos) << console;
  EXPECT_NE(dom.find("<pre id=\"layout-check\">ok</pre>"), std::string::npos) << layout_findings(dom);
  if (quadid::report::have_uplot()) {
    EXPECT_EQ(count(dom, "<canvas"), 8u);
  }
  EXPECT_NE(dom.find("(N m)^2/Hz) x1e-"), std::string::npos);  // the torque spectra in units of a power of ten
}
