// Report rendering: tables align, SVG is well-formed and carries labels and legend.
#include "quadid/report.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace quadid::report;

TEST(Report, TextTableAlignsColumns) {
  Table t;
  t.title = "T";
  t.header = {"name", "value (kg)"};
  t.rows = {{"m", "1.82"}, {"Ixx", "0.012"}};
  const std::string s = t.to_text();
  // Names padded to the widest name ("name", 4), values right-aligned to the
  // widest value ("value (kg)", 10), two spaces between columns.
  EXPECT_NE(s.find("\nm           1.82\n"), std::string::npos) << s;
  EXPECT_NE(s.find("\nIxx        0.012\n"), std::string::npos) << s;
  EXPECT_NE(t.to_markdown().find("| m | 1.82 |"), std::string::npos);
}

TEST(Report, MarkdownEscapesPipesInCells) {
  Table t;
  t.header = {"constraint", "|phi| (deg)"};
  t.rows = {{"a|b", "5.73"}};
  const std::string md = t.to_markdown();
  // Every row keeps its two cells: a bare | would split one into two.
  EXPECT_NE(md.find("| constraint | \\|phi\\| (deg) |\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| a\\|b | 5.73 |\n"), std::string::npos) << md;
}

TEST(Report, TextTableKeepsLongNamesApart) {
  Table t;
  t.header = {"Error", "e_a-very-long-reference-name", "e_another-long-set-name"};
  t.rows = {{"e_x", "0.00123", "0.00456"}};
  const std::string s = t.to_text();
  EXPECT_NE(s.find("e_a-very-long-reference-name  e_another-long-set-name"), std::string::npos) << s;
}

TEST(Report, HtmlTableMarksNegativeImprovementRed) {
  Table t;
  t.header = {"e", "P_imp%"};
  t.rows = {{"x", "-4.03"}, {"y", "5.38"}};
  const std::string h = t.to_html();
  EXPECT_NE(h.find("<td class=\"neg\">-4.03</td>"), std::string::npos);
  EXPECT_NE(h.find("<td class=\"pos\">5.38</td>"), std::string::npos);
}

TEST(Report, SvgHasAxesLabelsLegendAndEscapes) {
  Plot p;
  p.title = "z <test> & more";
  p.xlabel = "time (s)";
  p.ylabel = "z (m)";
  for (int k = 0; k < 6; ++k) {
    Series s;
    s.label = k == 0 ? "Exp" : "set" + std::to_string(k);
    for (int i = 0; i < 5000; ++i) {
      s.x.push_back(i * 0.01);
      s.y.push_back(std::sin(i * 0.01 + k));
    }
    p.series.push_back(s);
  }
  const std::string svg = render_svg(p);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("time (s)"), std::string::npos);
  EXPECT_NE(svg.find("z (m)"), std::string::npos);
  EXPECT_NE(svg.find("z &lt;test&gt; &amp; more"), std::string::npos);
  EXPECT_EQ(svg.find("<test>"), std::string::npos);
  for (int k = 1; k < 6; ++k) EXPECT_NE(svg.find(">set" + std::to_string(k) + "<"), std::string::npos);
  EXPECT_NE(svg.find("stroke=\"#000000\""), std::string::npos);  // Exp is black, as in the paper
  // Decimation keeps the file small: 5000 points per curve -> at most max_points vertices.
  size_t vertices = 0;
  for (char c : svg) vertices += (c == 'L');
  EXPECT_LE(vertices, 6u * 1500u);
  EXPECT_GT(vertices, 6u * 500u);
}

TEST(Report, NonFiniteValuesBreakTheLineInsteadOfPrintingNaN) {
  Plot p;
  p.xlabel = "t (s)";
  p.ylabel = "y (m)";
  p.series.push_back({"a", {0, 1, 2, 3}, {0, 1, NAN, 3}, "", false, 1.5});
  const std::string svg = render_svg(p);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(fixed(NAN, 3), "n/a");
  EXPECT_EQ(sig(0.015371, 4), "0.01537");
  EXPECT_EQ(sig(1.822461, 6), "1.82246");
}

TEST(Report, HtmlDocumentIsSelfContained) {
  HtmlDocument d("Report");
  d.heading("Section");
  d.paragraph("a < b");
  Plot p;
  p.xlabel = "x (m)";
  p.ylabel = "y (m)";
  p.series.push_back({"path", {0, 1}, {0, 1}, "", false, 1.5});
  d.figure(p, "caption");
  const std::string h = d.str();
  EXPECT_NE(h.find("<!DOCTYPE html>"), std::string::npos);
  EXPECT_NE(h.find("a &lt; b"), std::string::npos);
  EXPECT_NE(h.find("Figure 1. caption"), std::string::npos);
  // One script only, the layout self-check that runs when the page is opened as #layout-check;
  // nothing fetched.
  const auto first = h.find("<script");
  ASSERT_NE(first, std::string::npos);
  EXPECT_EQ(h.find("<script", first + 1), std::string::npos);
  EXPECT_NE(h.find("#layout-check", first), std::string::npos);
  EXPECT_EQ(h.find("src="), std::string::npos);
}

// The one tick labelling of every figure (issue 42): short labels that tell the
// ticks apart, and label x 10^e + offset gives the tick back.
TEST(TickLabels, ShortDistinctLabelsThatReadBackToTheTicks) {
  struct Case {
    double first, step;
    int n;
  };
  for (const Case& c : {Case{0.002688, 2e-6, 5}, Case{0.0, 20000.0, 4}, Case{0.0, 0.5, 3}, Case{-0.04, 0.02, 5},
                        Case{1.2e-5, 2e-7, 6}, Case{-3.0, 1.0, 7}}) {
    std::vector<double> t;
    for (int i = 0; i < c.n; ++i) t.push_back(c.first + i * c.step);
    const quadid::report::TickLabels l = quadid::report::tick_labels(t, c.step);
    ASSERT_EQ(l.labels.size(), t.size());
    // Read the shared exponent and offset back from the suffix.
    int e = 0;
    double offset = 0.0;
    const auto x = l.suffix.find("10^");
    if (x != std::string::npos) e = std::stoi(l.suffix.substr(x + 3));
    const auto plus = l.suffix.find(" + "), minus = l.suffix.find(" - ");
    if (plus != std::string::npos) offset = std::stod(l.suffix.substr(plus + 3));
    if (minus != std::string::npos) offset = -std::stod(l.suffix.substr(minus + 3));
    for (size_t i = 0; i < t.size(); ++i) {
      EXPECT_LE(l.labels[i].size(), 6u) << l.labels[i] << " for " << t[i];
      EXPECT_NE(l.labels[i], "-0") << "no negative zero";
      EXPECT_NEAR(std::stod(l.labels[i]) * std::pow(10.0, e) + offset, t[i], 1e-3 * c.step) << l.labels[i] << l.suffix;
      if (i) {
        EXPECT_NE(l.labels[i], l.labels[i - 1]) << "ticks told apart";
      }
    }
  }
  EXPECT_EQ(quadid::report::tick_labels({0.0, 0.5, 1.0}, 0.5).suffix, "");
}
