#include "gyrotc/app/report/svg_plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app::plot {
namespace {

constexpr std::array<const char*, 8> kPalette{"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                              "#9467bd", "#8c564b", "#e377c2", "#17becf"};
constexpr double kLeft = 80.0;
constexpr double kTop = 40.0;
constexpr double kSegmentRow = 16.0;  // the segments' labels, above the top panel
constexpr double kGap = 30.0;
constexpr double kBottom = 50.0;
constexpr double kRightAxis = 60.0;  // room for the right axis' ticks and title
constexpr double kRightPad = 16.0;

std::string esc(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Pixel coordinates: a tenth of a pixel is finer than any screen shows.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string tick_label(double v, Scale scale) {
  char buf[32];
  if (scale == Scale::log) {
    const int k = static_cast<int>(std::lround(std::log10(v)));
    if (k >= -3 && k <= 4) std::snprintf(buf, sizeof buf, "%g", v);
    else std::snprintf(buf, sizeof buf, "1e%d", k);
  } else {
    std::snprintf(buf, sizeof buf, "%g", std::fabs(v) < 1e-12 ? 0.0 : v);
  }
  return buf;
}

bool plottable(double v, Scale scale) { return std::isfinite(v) && (scale == Scale::linear || v > 0.0); }

// The data range of an axis, widened to ticks; a map from value to [0, 1].
struct Range {
  Scale scale = Scale::linear;
  double lo = 0.0;
  double hi = 1.0;
  std::vector<double> ticks;

  double frac(double v) const {
    if (scale == Scale::log) return (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
    return (v - lo) / (hi - lo);
  }
};

Range make_range(double lo, double hi, const Axis& axis) {
  Range r;
  r.scale = axis.scale;
  if (axis.min && axis.max) {
    r.lo = *axis.min;
    r.hi = *axis.max;
    if (axis.scale == Scale::log) {
      r.ticks = log_decade_ticks(r.lo, r.hi);
    } else {
      for (double t : linear_ticks(r.lo, r.hi)) {
        if (t >= r.lo - 1e-9 * (r.hi - r.lo) && t <= r.hi + 1e-9 * (r.hi - r.lo)) r.ticks.push_back(t);
      }
    }
    return r;
  }
  if (axis.scale == Scale::log) {
    r.lo = std::pow(10.0, std::floor(std::log10(lo)));
    r.hi = std::pow(10.0, std::ceil(std::log10(hi)));
    if (r.hi <= r.lo) r.hi = r.lo * 10.0;
    if (axis.tight) {
      r.lo = lo;
      r.hi = hi > lo ? hi : lo * 10.0;
    }
    r.ticks = log_decade_ticks(r.lo, r.hi);
  } else {
    if (hi <= lo) {
      const double pad = lo == 0.0 ? 1.0 : std::fabs(lo) * 0.1;
      lo -= pad;
      hi += pad;
    }
    const std::vector<double> ticks = linear_ticks(lo, hi);
    if (axis.tight) {
      r.lo = lo;
      r.hi = hi;
      for (double t : ticks) {
        if (t >= lo - 1e-9 * (hi - lo) && t <= hi + 1e-9 * (hi - lo)) r.ticks.push_back(t);
      }
    } else {
      r.ticks = ticks;
      r.lo = std::min(lo, ticks.front());
      r.hi = std::max(hi, ticks.back());
    }
  }
  return r;
}

Range range_of(const std::vector<const Series*>& series, bool use_x, const Axis& axis, Scale x_scale) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const Series* s : series) {
    for (std::size_t i = 0; i < s->x.size(); ++i) {
      if (!plottable(s->x[i], x_scale) || !std::isfinite(s->y[i])) continue;
      const double v = use_x ? s->x[i] : s->y[i];
      if (!plottable(v, axis.scale)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!std::isfinite(lo)) {
    const bool log = axis.scale == Scale::log;
    return make_range(log ? 1.0 : 0.0, log ? 10.0 : 1.0, axis);
  }
  return make_range(lo, hi, axis);
}

void check_axis(const Figure& f, const Axis& a) {
  if (a.min.has_value() != a.max.has_value()) {
    throw std::invalid_argument("plot '" + f.title + "': axis '" + a.title + "' has one fixed limit");
  }
  if (a.min && !(*a.max > *a.min)) {
    throw std::invalid_argument("plot '" + f.title + "': axis '" + a.title + "' has max <= min");
  }
}

void check(const Figure& f) {
  if (f.panels.empty()) throw std::invalid_argument("plot '" + f.title + "': no panels");
  check_axis(f, f.x);
  for (const auto& p : f.panels) {
    check_axis(f, p.y);
    check_axis(f, p.y2);
    if (p.series.empty()) throw std::invalid_argument("plot '" + f.title + "': a panel without series");
    for (const auto& s : p.series) {
      if (s.x.empty()) throw std::invalid_argument("plot '" + f.title + "': series '" + s.label + "' has no points");
      if (s.x.size() != s.y.size()) {
        throw std::invalid_argument("plot '" + f.title + "': series '" + s.label + "' has x and y of different lengths");
      }
      const Scale ys = s.right_axis ? p.y2.scale : p.y.scale;
      bool any = false;
      for (std::size_t i = 0; i < s.x.size() && !any; ++i) any = plottable(s.x[i], f.x.scale) && plottable(s.y[i], ys);
      if (!any) throw std::invalid_argument("plot '" + f.title + "': series '" + s.label + "' has no plottable point");
    }
  }
}

// The path of a series: a new sub-path after every unplottable point; where
// several points fall in one pixel column, only the first, the lowest, the
// highest and the last of them (in their order) are kept.
template <typename Px, typename Py>
std::string series_path(const Series& s, Scale xs, Scale ys, Px px, Py py) {
  std::string d;
  bool pen_down = false;
  std::vector<std::size_t> bucket;  // indices of the current column's points
  long column = std::numeric_limits<long>::min();
  auto flush = [&] {
    if (bucket.empty()) return;
    std::size_t lo = bucket.front(), hi = bucket.front();
    for (std::size_t i : bucket) {
      if (s.y[i] < s.y[lo]) lo = i;
      if (s.y[i] > s.y[hi]) hi = i;
    }
    std::size_t keep[4] = {bucket.front(), std::min(lo, hi), std::max(lo, hi), bucket.back()};
    std::size_t last = std::numeric_limits<std::size_t>::max();
    for (std::size_t i : keep) {
      if (i == last) continue;
      d += (pen_down ? " L" : " M") + num(px(s.x[i])) + " " + num(py(s.y[i]));
      pen_down = true;
      last = i;
    }
    bucket.clear();
  };
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!plottable(s.x[i], xs) || !plottable(s.y[i], ys)) {
      flush();
      pen_down = false;
      column = std::numeric_limits<long>::min();
      continue;
    }
    const long c = std::lround(std::floor(px(s.x[i])));
    if (c != column) {
      flush();
      column = c;
    }
    bucket.push_back(i);
  }
  flush();
  return d.empty() ? d : d.substr(1);
}

}  // namespace

Series power_law_line(std::string label, double value_at_ref, double ref_x, double slope, double x_min,
                      double x_max, std::string color) {
  Series s;
  s.label = std::move(label);
  s.x = {x_min, x_max};
  s.y = {value_at_ref * std::pow(x_min / ref_x, slope), value_at_ref * std::pow(x_max / ref_x, slope)};
  s.color = std::move(color);
  s.dashed = true;
  return s;
}

std::vector<double> log_decade_ticks(double lo, double hi) {
  std::vector<double> ticks;
  if (!(lo > 0.0) || !(hi >= lo)) return ticks;
  for (int k = static_cast<int>(std::ceil(std::log10(lo) - 1e-9)); k <= static_cast<int>(std::floor(std::log10(hi) + 1e-9)); ++k) {
    ticks.push_back(std::pow(10.0, k));
  }
  return ticks;
}

std::vector<double> linear_ticks(double lo, double hi, int target) {
  const double span = hi - lo;
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double v = std::floor(lo / step) * step; v <= hi + step * 0.999; v += step) ticks.push_back(v);
  return ticks;
}

std::string render_svg(const Figure& f) {
  check(f);
  bool any_right = false;
  std::vector<const Series*> all;
  for (const auto& p : f.panels) {
    for (const auto& s : p.series) {
      all.push_back(&s);
      any_right = any_right || s.right_axis;
    }
  }
  const double plot_w = f.width_px - kLeft - f.legend_width_px - (any_right ? kRightAxis : kRightPad);
  const double legend_x = kLeft + plot_w + (any_right ? kRightAxis : kRightPad);
  const double top0 = kTop + (f.segments.empty() ? 0.0 : kSegmentRow);
  const double height = top0 + static_cast<double>(f.panels.size()) * (f.panel_height_px + kGap) + kBottom - kGap;
  const Range xr = range_of(all, true, f.x, f.x.scale);
  auto px = [&](double x) { return kLeft + xr.frac(x) * plot_w; };
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << num(f.width_px) << "\" height=\"" << num(height)
    << "\" viewBox=\"0 0 " << num(f.width_px) << " " << num(height) << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
    << "<rect x=\"0\" y=\"0\" width=\"" << num(f.width_px) << "\" height=\"" << num(height) << "\" fill=\"white\"/>\n"
    << "<text x=\"" << num(kLeft + plot_w / 2) << "\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">" << esc(f.title)
    << "</text>\n";
  for (const Segment& g : f.segments) {
    const double from = std::max(g.start, xr.lo), to = std::min(g.end, xr.hi);
    if (!(to > from) || !plottable(from, f.x.scale) || !plottable(to, f.x.scale)) continue;
    o << "<text class=\"segment\" x=\"" << num((px(from) + px(to)) / 2) << "\" y=\"" << num(top0 - 5)
      << "\" text-anchor=\"middle\" font-size=\"11\" fill=\"#555555\">" << esc(g.label) << "</text>\n";
  }
  for (std::size_t pi = 0; pi < f.panels.size(); ++pi) {
    const Panel& p = f.panels[pi];
    std::size_t colour = 0;  // each panel from the palette's start: the same quantity, the same colour
    const double top = top0 + static_cast<double>(pi) * (f.panel_height_px + kGap);
    const double bottom = top + f.panel_height_px;
    std::vector<const Series*> left, right;
    for (const auto& s : p.series) (s.right_axis ? right : left).push_back(&s);
    const Range yl = range_of(left.empty() ? right : left, false, p.y, f.x.scale);
    const Range yr = right.empty() ? yl : range_of(right, false, p.y2, f.x.scale);
    auto py = [&](const Range& r, double y) { return bottom - r.frac(y) * f.panel_height_px; };
    const std::string clip = "clip" + std::to_string(pi);
    o << "<g class=\"panel\">\n<clipPath id=\"" << clip << "\"><rect x=\"" << num(kLeft) << "\" y=\"" << num(top)
      << "\" width=\"" << num(plot_w) << "\" height=\"" << num(f.panel_height_px) << "\"/></clipPath>\n";
    // Bands first, under the grid and the data.
    for (const Band& b : p.bands) {
      double x0 = kLeft, x1 = kLeft + plot_w, y0 = top, y1 = bottom;
      if (b.vertical) {
        x0 = px(std::max(b.from, xr.lo));
        x1 = px(std::min(b.to, xr.hi));
      } else {
        y0 = py(yl, b.to);
        y1 = py(yl, b.from);
      }
      o << "<rect class=\"band\" clip-path=\"url(#" << clip << ")\" x=\"" << num(std::min(x0, x1)) << "\" y=\""
        << num(std::min(y0, y1)) << "\" width=\"" << num(std::fabs(x1 - x0)) << "\" height=\""
        << num(std::fabs(y1 - y0)) << "\" fill=\"" << esc(b.color) << "\" fill-opacity=\"0.15\"/>\n";
    }
    // x ticks (labels on the bottom panel only), grid lines on every panel.
    for (double t : xr.ticks) {
      const double x = px(t);
      o << "<line class=\"grid\" x1=\"" << num(x) << "\" y1=\"" << num(top) << "\" x2=\"" << num(x) << "\" y2=\""
        << num(bottom) << "\" stroke=\"#dddddd\"/>\n";
      if (pi + 1 == f.panels.size()) {
        o << "<text class=\"tick-x\" x=\"" << num(x) << "\" y=\"" << num(bottom + 16) << "\" text-anchor=\"middle\">"
          << tick_label(t, xr.scale) << "</text>\n";
      }
    }
    for (const Segment& g : f.segments) {
      if (!plottable(g.start, f.x.scale) || g.start <= xr.lo || g.start >= xr.hi) continue;
      o << "<line class=\"segment\" x1=\"" << num(px(g.start)) << "\" y1=\"" << num(top) << "\" x2=\""
        << num(px(g.start)) << "\" y2=\"" << num(bottom) << "\" stroke=\"#999999\" stroke-dasharray=\"2 3\"/>\n";
    }
    auto y_ticks = [&](const Range& r, bool on_right) {
      for (double t : r.ticks) {
        const double y = py(r, t);
        if (!on_right) {
          o << "<line class=\"grid\" x1=\"" << num(kLeft) << "\" y1=\"" << num(y) << "\" x2=\"" << num(kLeft + plot_w)
            << "\" y2=\"" << num(y) << "\" stroke=\"#dddddd\"/>\n";
        }
        const double x = on_right ? kLeft + plot_w + 6 : kLeft - 6;
        o << "<text class=\"tick-y\" x=\"" << num(x) << "\" y=\"" << num(y + 4) << "\" text-anchor=\""
          << (on_right ? "start" : "end") << "\">" << tick_label(t, r.scale) << "</text>\n";
      }
    };
    y_ticks(yl, false);
    const double mid = (top + bottom) / 2;
    o << "<text class=\"axis-title\" x=\"18\" y=\"" << num(mid) << "\" text-anchor=\"middle\" transform=\"rotate(-90 18 "
      << num(mid) << ")\">" << esc(p.y.title) << "</text>\n";
    if (!right.empty()) {
      y_ticks(yr, true);
      const double xt = kLeft + plot_w + kRightAxis - 12;
      o << "<text class=\"axis-title\" x=\"" << num(xt) << "\" y=\"" << num(mid)
        << "\" text-anchor=\"middle\" transform=\"rotate(90 " << num(xt) << " " << num(mid) << ")\">"
        << esc(p.y2.title) << "</text>\n";
    }
    // Series, then the frame over them; the legend in its column.
    double legend_y = top + 12;
    for (const auto& s : p.series) {
      const std::string color = s.color.empty() ? kPalette[colour++ % kPalette.size()] : s.color;
      const Range& r = s.right_axis ? yr : yl;
      const Scale ys = s.right_axis ? p.y2.scale : p.y.scale;
      if (s.markers) {
        o << "<g class=\"series\" clip-path=\"url(#" << clip << ")\" fill=\"" << esc(color) << "\">";
        for (std::size_t i = 0; i < s.x.size(); ++i) {
          if (!plottable(s.x[i], f.x.scale) || !plottable(s.y[i], ys)) continue;
          o << "<circle cx=\"" << num(px(s.x[i])) << "\" cy=\"" << num(py(r, s.y[i])) << "\" r=\"2.5\"/>";
        }
        o << "</g>\n";
      } else {
        const std::string d = series_path(s, f.x.scale, ys, px, [&](double y) { return py(r, y); });
        o << "<path class=\"series\" clip-path=\"url(#" << clip << ")\" fill=\"none\" stroke=\"" << esc(color)
          << "\" stroke-width=\"" << num(s.width_px) << "\" stroke-linejoin=\"round\""
          << (s.dashed ? " stroke-dasharray=\"6 4\"" : "") << " d=\"" << d << "\"/>\n";
      }
      if (s.label.empty()) continue;
      if (s.markers) {
        o << "<circle cx=\"" << num(legend_x + 11) << "\" cy=\"" << num(legend_y - 4) << "\" r=\"2.5\" fill=\""
          << esc(color) << "\"/>\n";
      } else {
        o << "<line x1=\"" << num(legend_x) << "\" y1=\"" << num(legend_y - 4) << "\" x2=\"" << num(legend_x + 22)
          << "\" y2=\"" << num(legend_y - 4) << "\" stroke=\"" << esc(color) << "\" stroke-width=\"2\""
          << (s.dashed ? " stroke-dasharray=\"6 4\"" : "") << "/>\n";
      }
      o << "<text class=\"legend\" x=\"" << num(legend_x + 28) << "\" y=\"" << num(legend_y) << "\" font-size=\"11\">"
        << esc(s.label) << (s.right_axis ? " (right axis)" : "") << "</text>\n";
      legend_y += 15;
    }
    for (const Band& b : p.bands) {
      if (b.label.empty()) continue;
      o << "<rect x=\"" << num(legend_x) << "\" y=\"" << num(legend_y - 10) << "\" width=\"22\" height=\"9\" fill=\""
        << esc(b.color) << "\" fill-opacity=\"0.3\"/>\n"
        << "<text class=\"legend\" x=\"" << num(legend_x + 28) << "\" y=\"" << num(legend_y) << "\" font-size=\"11\">"
        << esc(b.label) << "</text>\n";
      legend_y += 15;
    }
    o << "<rect x=\"" << num(kLeft) << "\" y=\"" << num(top) << "\" width=\"" << num(plot_w) << "\" height=\""
      << num(f.panel_height_px) << "\" fill=\"none\" stroke=\"black\"/>\n";
    o << "</g>\n";
  }
  o << "<text class=\"axis-title\" x=\"" << num(kLeft + plot_w / 2) << "\" y=\"" << num(height - 10)
    << "\" text-anchor=\"middle\">" << esc(f.x.title) << "</text>\n</svg>\n";
  return o.str();
}

void write_svg(const Figure& figure, const std::string& path) {
  const std::string svg = render_svg(figure);
  std::ofstream out(path, std::ios::binary);
  out << svg;
  out.flush();
  if (!out) throw RuntimeFailure(path + ": cannot write the plot");
}

}  // namespace gyrotc::app::plot
