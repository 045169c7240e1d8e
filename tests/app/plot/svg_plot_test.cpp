#include <algorithm>
#include <cmath>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyrotc/app/report/svg_plot.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::app::plot;

namespace {

// Tag balance of an XML document: every element closed in order, every
// attribute value quoted. Enough to show the writer emits well-formed XML.
bool well_formed(const std::string& xml, std::string& why) {
  std::vector<std::string> stack;
  std::size_t i = 0;
  while ((i = xml.find('<', i)) != std::string::npos) {
    const std::size_t end = xml.find('>', i);
    if (end == std::string::npos) { why = "unterminated tag"; return false; }
    const std::string tag = xml.substr(i + 1, end - i - 1);
    i = end + 1;
    if (tag.empty()) { why = "empty tag"; return false; }
    if (tag[0] == '?' || tag[0] == '!') continue;
    if (tag[0] == '/') {
      if (stack.empty() || stack.back() != tag.substr(1)) { why = "mismatched </" + tag.substr(1) + ">"; return false; }
      stack.pop_back();
      continue;
    }
    const std::string name = tag.substr(0, tag.find_first_of(" /"));
    if (std::count(tag.begin(), tag.end(), '"') % 2 != 0) { why = "odd quotes in <" + name + ">"; return false; }
    if (tag.back() != '/') stack.push_back(name);
  }
  if (!stack.empty()) { why = "unclosed <" + stack.back() + ">"; return false; }
  return true;
}

std::vector<std::pair<double, std::string>> x_tick_labels(const std::string& svg) {
  std::vector<std::pair<double, std::string>> out;
  const std::regex re("<text class=\"tick-x\" x=\"([0-9.]+)\"[^>]*>([^<]*)</text>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it) {
    out.emplace_back(std::stod((*it)[1]), (*it)[2]);
  }
  return out;
}

Series line(std::string label, std::vector<double> x, std::vector<double> y) {
  Series s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  return s;
}

}  // namespace

TEST_CASE("the SVG is well-formed XML with a legend, titles and escaped text") {
  Figure f;
  f.title = "T & <test>";
  f.x.title = "time_s";
  Panel p;
  p.y.title = "temp_c";
  p.y2.title = "tec_a";
  p.series.push_back(line("casing \"c\"", {0, 1, 2}, {20, 21, 22}));
  Series current = line("tec", {0, 1, 2}, {0.1, 0.2, 0.3});
  current.right_axis = true;
  p.series.push_back(current);
  f.panels = {p, p};
  const std::string svg = render_svg(f);
  std::string why;
  INFO(why);
  CHECK(well_formed(svg, why));
  CHECK(svg.find("T &amp; &lt;test&gt;") != std::string::npos);
  CHECK(svg.find("casing &quot;c&quot;") != std::string::npos);
  CHECK(svg.find(">time_s</text>") != std::string::npos);
  CHECK(svg.find(">tec_a</text>") != std::string::npos);
  CHECK(std::count(svg.begin(), svg.end(), '\n') > 10);
  // Two panels, each with two series.
  std::size_t paths = 0;
  for (std::size_t i = 0; (i = svg.find("class=\"series\"", i)) != std::string::npos; ++i) ++paths;
  CHECK(paths == 4);
}

TEST_CASE("a log axis has a labelled tick at every decade, equally spaced") {
  CHECK(log_decade_ticks(0.01, 1000.0) == std::vector<double>{0.01, 0.1, 1.0, 10.0, 100.0, 1000.0});
  Figure f;
  f.x.scale = Scale::log;
  Panel p;
  p.y.scale = Scale::log;
  p.series.push_back(line("adev", {0.02, 0.5, 700.0}, {1.0, 0.1, 0.01}));
  f.panels = {p};
  const auto ticks = x_tick_labels(render_svg(f));
  REQUIRE(ticks.size() == 6);  // the range widens to whole decades: 0.01 .. 1000
  CHECK(ticks.front().second == "0.01");
  CHECK(ticks.back().second == "1000");
  const double step = ticks[1].first - ticks[0].first;
  CHECK(step > 50.0);
  for (std::size_t i = 1; i < ticks.size(); ++i) CHECK(ticks[i].first - ticks[i - 1].first == Approx(step).margin(0.02));
}

TEST_CASE("linear ticks are round and cover the range") {
  const auto t = linear_ticks(0.3, 9.7);
  REQUIRE(t.size() >= 4);
  CHECK(t.front() <= 0.3);
  CHECK(t.back() >= 9.7);
  CHECK(t[1] - t[0] == Approx(2.0));
}

TEST_CASE("NaN points break a line into separate sub-paths") {
  Figure f;
  Panel p;
  p.series.push_back(line("gappy", {0, 1, 2, 3, 4}, {1, 2, std::nan(""), 4, 5}));
  f.panels = {p};
  const std::string svg = render_svg(f);
  const std::regex re(" d=\"([^\"]*)\"");
  std::smatch m;
  REQUIRE(std::regex_search(svg, m, re));
  const std::string d = m[1];
  CHECK(std::count(d.begin(), d.end(), 'M') == 2);
  CHECK(std::count(d.begin(), d.end(), 'L') == 2);
}

TEST_CASE("power-law reference lines are straight two-point dashed series") {
  const Series s = power_law_line("N", 0.01, 1.0, -0.5, 0.01, 100.0);
  REQUIRE(s.x.size() == 2);
  CHECK(s.dashed);
  CHECK(s.y[0] == Approx(0.1));
  CHECK(s.y[1] == Approx(0.001));
}

TEST_CASE("an empty series, a figure without panels or mismatched x/y are errors") {
  Figure f;
  CHECK_THROWS_AS(render_svg(f), std::invalid_argument);
  Panel p;
  p.series.push_back(line("empty", {}, {}));
  f.panels = {p};
  CHECK_THROWS_WITH(render_svg(f), Catch::Contains("'empty' has no points"));
  f.panels[0].series[0] = line("odd", {1, 2}, {1});
  CHECK_THROWS_AS(render_svg(f), std::invalid_argument);
  f.panels[0].series[0] = line("nan", {1, 2}, {std::nan(""), std::nan("")});
  CHECK_THROWS_AS(render_svg(f), std::invalid_argument);
}

namespace {

// The points of the first series path, in pixels. Read without std::regex:
// libstdc++'s matcher recurses once per character, and a path of a few
// thousand points overflowed the stack of the sanitizer build.
std::vector<std::pair<double, double>> path_points(const std::string& svg) {
  std::vector<std::pair<double, double>> out;
  const std::size_t path = svg.find("<path class=\"series\"");
  if (path == std::string::npos) return out;
  const std::size_t start = svg.find(" d=\"", path);
  if (start == std::string::npos) return out;
  std::istringstream d(svg.substr(start + 4, svg.find('"', start + 4) - (start + 4)));
  char command = 0;
  double x = 0.0;
  double y = 0.0;
  while (d >> command >> x >> y) {
    if (command == 'M' || command == 'L') out.emplace_back(x, y);
  }
  return out;
}

Figure one_series(Series s) {
  Figure f;
  f.title = "t";
  Panel p;
  p.series = {std::move(s)};
  f.panels = {p};
  return f;
}

}  // namespace

TEST_CASE("a series denser than the pixels is drawn from each column's extremes, a one-sample spike kept") {
  std::vector<double> x, y;
  for (int i = 0; i < 100000; ++i) {
    x.push_back(i);
    y.push_back(std::sin(i * 1e-4));
  }
  y[54321] = 5.0;  // one sample: the plot must still show it
  const std::string svg = render_svg(one_series(line("dense", x, y)));
  const auto pts = path_points(svg);
  const Figure f = one_series(line("dense", x, y));
  CHECK(pts.size() <= static_cast<std::size_t>(4 * f.width_px));
  CHECK(pts.size() > 500);
  const double top = std::min_element(pts.begin(), pts.end(), [](auto a, auto b) { return a.second < b.second; })->second;
  CHECK(top == Approx(40.0).margin(0.2));  // the spike reaches the panel's top (5 is the range's maximum)
  CHECK(svg.size() < 60000);
}

TEST_CASE("fixed limits hold whatever the data, ticks stay inside them, the data outside is clipped") {
  Series s = line("e", {0, 1, 2}, {-30.0, 0.1, 0.2});
  Figure f = one_series(s);
  f.panels[0].y.min = -1.0;
  f.panels[0].y.max = 1.0;
  const std::string svg = render_svg(f);
  const std::regex re("<text class=\"tick-y\"[^>]*>([^<]*)</text>");
  std::vector<double> ticks;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it) {
    ticks.push_back(std::stod((*it)[1]));
  }
  REQUIRE(ticks.size() >= 3);
  CHECK(ticks.front() == Approx(-1.0));
  CHECK(ticks.back() == Approx(1.0));
  CHECK(svg.find("clip-path=\"url(#clip0)\"") != std::string::npos);
}

TEST_CASE("an axis with one fixed limit, or max below min, is refused") {
  Figure f = one_series(line("a", {0, 1}, {0, 1}));
  f.panels[0].y.min = 0.0;
  CHECK_THROWS_WITH(render_svg(f), Catch::Contains("one fixed limit"));
  f.panels[0].y.max = -1.0;
  CHECK_THROWS_WITH(render_svg(f), Catch::Contains("max <= min"));
}

TEST_CASE("a tight x axis ends at the data, not at the next round tick") {
  Figure f = one_series(line("a", {0, 17460}, {0, 1}));
  f.x.tight = true;
  const auto ticks = x_tick_labels(render_svg(f));
  REQUIRE_FALSE(ticks.empty());
  CHECK(ticks.back().second != "20000");
  f.x.tight = false;
  CHECK(x_tick_labels(render_svg(f)).back().second == "20000");
}

TEST_CASE("legends sit right of the data, and a series without a label has no entry") {
  Figure f = one_series(line("shown", {0, 1}, {0, 1}));
  f.panels[0].series.push_back(line("", {0, 1}, {1, 0}));
  const std::string svg = render_svg(f);
  const double plot_right = f.width_px - f.legend_width_px;
  const std::regex re("<text class=\"legend\" x=\"([0-9.]+)\"[^>]*>([^<]*)</text>");
  int entries = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it) {
    ++entries;
    CHECK(std::stod((*it)[1]) > plot_right);
    CHECK((*it)[2] == "shown");
  }
  CHECK(entries == 1);
}

TEST_CASE("segments label their stretch above the top panel and mark their start in every panel") {
  Figure f = one_series(line("a", {0, 100}, {0, 1}));
  f.panels.push_back(f.panels[0]);
  f.segments = {{"B", 0, 40}, {"C", 40, 100}};
  const std::string svg = render_svg(f);
  CHECK(svg.find(">B</text>") != std::string::npos);
  CHECK(svg.find(">C</text>") != std::string::npos);
  std::size_t lines = 0;
  for (std::size_t i = 0; (i = svg.find("<line class=\"segment\"", i)) != std::string::npos; ++i) ++lines;
  CHECK(lines == 2);  // C's start in both panels; B starts at the axis' edge
}

TEST_CASE("a band is shaded and named in the legend") {
  Figure f = one_series(line("e", {0, 1}, {-1, 1}));
  f.panels[0].bands = {{"±0.3 °C band", -0.3, 0.3, "#2ca02c", false}};
  const std::string svg = render_svg(f);
  CHECK(svg.find("<rect class=\"band\"") != std::string::npos);
  CHECK(svg.find(">±0.3 °C band</text>") != std::string::npos);
}
