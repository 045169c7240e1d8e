#pragma once

#include <string>
#include <vector>

// A small dependency-free SVG plot writer for the reports of `gyrotc allan`,
// `simulate` and `identify`: line series with a legend, linear or log axes
// (decade ticks and labels), axis titles, a right-hand y axis, stacked panels
// sharing the x axis. Non-finite points (and non-positive ones on a log axis)
// break a line instead of joining across the gap.
namespace gyrotc::app::plot {

enum class Scale { linear, log };

struct Axis {
  std::string title;
  Scale scale = Scale::linear;
};

struct Series {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  std::string color;         // empty: the next colour of the palette
  bool dashed = false;       // reference lines
  bool right_axis = false;   // plotted against the panel's y2 axis
};

struct Panel {
  Axis y;
  Axis y2;                   // used when a series has right_axis
  std::vector<Series> series;
};

struct Figure {
  std::string title;
  Axis x;
  std::vector<Panel> panels; // stacked top to bottom, sharing x
  double width_px = 900.0;
  double panel_height_px = 320.0;
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
// series, a series without points, x/y of different lengths or a series with
// no plottable point.
std::string render_svg(const Figure& figure);
// RuntimeFailure when the file cannot be written.
void write_svg(const Figure& figure, const std::string& path);

}  // namespace gyrotc::app::plot
