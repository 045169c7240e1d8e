#pragma once

#include <optional>
#include <string>
#include <vector>

// A small dependency-free SVG plot writer for the reports of `gyrotc allan`,
// `simulate`, `tune` and `identify`: line series with a legend beside the
// data (never over it), linear or log axes (decade ticks and labels), fixed or
// data-driven limits, axis titles, a right-hand y axis, stacked panels sharing
// the x axis, shaded bands and spans, labelled segments (chamber
// segment letters). Non-finite points (and non-positive ones on a log axis) break a
// line instead of joining across the gap. A series denser than the plot's
// pixels is drawn from the first, lowest, highest and last point of each pixel
// column: the same picture as every point, at a fraction of the file size.
namespace gyrotc::app::plot {

enum class Scale { linear, log };

struct Axis {
  std::string title;
  Scale scale = Scale::linear;
  // Fixed limits (both or neither; linear axes): a series outside is clipped,
  // so runs plotted on the same limits compare at a glance.
  std::optional<double> min;
  std::optional<double> max;
  bool tight = false;  // the data's own range, not widened to round ticks
};

struct Series {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  std::string color;         // empty: the next colour of the palette
  bool dashed = false;       // reference lines
  bool right_axis = false;   // plotted against the panel's y2 axis
  double width_px = 1.3;     // a wide light line under a thin dark one: data and model
  bool markers = false;      // a dot at each point and no line: measured points beside a model
};

// A shaded horizontal band (e.g. a tolerance, +/-0.3 C) or, with
// vertical = true, a shaded x span (e.g. the window a figure is judged on).
struct Band {
  std::string label;  // legend entry; empty: none
  double from = 0.0;
  double to = 0.0;
  std::string color = "#2ca02c";
  bool vertical = false;
};

struct Panel {
  Axis y;
  Axis y2;                   // used when a series has right_axis
  std::vector<Series> series;
  std::vector<Band> bands;   // drawn under the series
};

// A labelled stretch of the x axis (e.g. a chamber segment): a dotted line
// at its start across every panel, its label centred above the top panel.
struct Segment {
  std::string label;
  double start = 0.0;
  double end = 0.0;
};

struct Figure {
  std::string title;
  Axis x;
  std::vector<Panel> panels; // stacked top to bottom, sharing x
  std::vector<Segment> segments;
  double width_px = 900.0;   // the plot area is this less the margins and the legend column
  double panel_height_px = 320.0;
  double legend_width_px = 200.0;  // the legend column, right of the data
};

// A straight reference line between x_min and x_max through y = value_at_ref
// * (x / ref_x)^slope: straight on log-log axes (Allan slope lines).
Series power_law_line(std::string label, double value_at_ref, double ref_x, double slope, double x_min,
                      double x_max, std::string color = "#555555");

// Decade tick values 10^k within [lo, hi] (lo > 0).
std::vector<double> log_decade_ticks(double lo, double hi);
// About `target` round (1, 2, 5 x 10^k) tick values covering [lo, hi].
std::vector<double> linear_ticks(double lo, double hi, int target = 6);

// Throws std::invalid_argument for a figure without panels, a panel without
// series, a series without points, x/y of different lengths, a series with
// no plottable point or an axis with one fixed limit, or max <= min.
std::string render_svg(const Figure& figure);
// RuntimeFailure when the file cannot be written.
void write_svg(const Figure& figure, const std::string& path);

}  // namespace gyrotc::app::plot
