// The reproduction report renders in a real browser: headless Chromium (Debian's
// `chromium` package) loads report.html, and the DOM it built holds every
// figure and table. Skipped where Chromium is not installed.
#include "cli_fixture.hpp"

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

}  // namespace

class ReportBrowser : public CliTest {};

TEST_F(ReportBrowser, ChromiumRendersEveryFigureAndTable) {
  const char* chrome = chromium();
  if (!chrome) GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  const CliRun r = run("reproduce --trajectory table2 --duration 20 --out " + path("rep"));
  ASSERT_EQ(r.rc, 0) << r.err;
  // The flags keep Chromium off the network (this machine has none) and out of the user's profile.
  const std::string flags = std::string("--headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
                                        "--disable-background-networking --disable-component-update --disable-sync "
                                        "--user-data-dir=") + path("profile") + " --window-size=1600,4000 ";
  const std::string url = "file://" + path("rep/report.html");
  const std::string dom_file = path("dom.html"), png = path("report.png");
  std::system((std::string(chrome) + " " + flags + "--dump-dom " + url + " > " + dom_file + " 2>/dev/null").c_str());
  std::system((std::string(chrome) + " " + flags + "--screenshot=" + png + " " + url + " > /dev/null 2>&1").c_str());
  const std::string dom = quadid::read_file(dom_file);
  // 14 figures of 2 + 1 + 3 + 3 + 2 + 1 + 1 + 3 + 3 + 3 + 3 + 2 + 2 + 3 = 32 plots (trajectory, mass,
  // moments, products, LS residuals and their spectra, path, position and its differences,
  // attitude and its differences, inputs in two rows of two, circle paths; see reproduction_html).
  EXPECT_EQ(count(dom, "<svg"), 32u);
  EXPECT_EQ(count(dom, "<figcaption>"), 14u);
  // Table 2, the constraint check, Table 3 and its errors, Tables 4 to 12, and the conclusions.
  EXPECT_EQ(count(dom, "<table>"), 14u);
  EXPECT_NE(dom.find("time (s)"), std::string::npos);
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_GT(std::filesystem::file_size(png), 100000u);  // a blank 1600x4000 page compresses to a few kB
}
