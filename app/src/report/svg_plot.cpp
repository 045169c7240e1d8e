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
constexpr double kRight = 80.0;
constexpr double kTop = 40.0;
constexpr double kGap = 50.0;
constexpr double kBottom = 50.0;

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

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
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

Range make_range(double lo, double hi, Scale scale) {
  Range r;
  r.scale = scale;
  if (scale == Scale::log) {
    r.lo = std::pow(10.0, std::floor(std::log10(lo)));
    r.hi = std::pow(10.0, std::ceil(std::log10(hi)));
    if (r.hi <= r.lo) r.hi = r.lo * 10.0;
    r.ticks = log_decade_ticks(r.lo, r.hi);
  } else {
    if (hi <= lo) {
      const double pad = lo == 0.0 ? 1.0 : std::fabs(lo) * 0.1;
      lo -= pad;
      hi += pad;
    }
    r.ticks = linear_ticks(lo, hi);
    r.lo = std::min(lo, r.ticks.front());
    r.hi = std::max(hi, r.ticks.back());
  }
  return r;
}

Range range_of(const std::vector<const Series*>& series, bool use_x, Scale scale) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const Series* s : series) {
    for (std::size_t i = 0; i < s->x.size(); ++i) {
      if (!plottable(s->x[i], use_x ? scale : Scale::linear) || !std::isfinite(s->y[i])) continue;
      const double v = use_x ? s->x[i] : s->y[i];
      if (!plottable(v, scale)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!std::isfinite(lo)) return make_range(scale == Scale::log ? 1.0 : 0.0, scale == Scale::log ? 10.0 : 1.0, scale);
  return make_range(lo, hi, scale);
}

void check(const Figure& f) {
  if (f.panels.empty()) throw std::invalid_argument("plot '" + f.title + "': no panels");
  for (const auto& p : f.panels) {
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
  const double plot_w = f.width_px - kLeft - kRight;
  const double height = kTop + static_cast<double>(f.panels.size()) * (f.panel_height_px + kGap) + kBottom - kGap;
  std::vector<const Series*> all;
  for (const auto& p : f.panels) {
    for (const auto& s : p.series) all.push_back(&s);
  }
  const Range xr = range_of(all, true, f.x.scale);
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << num(f.width_px) << "\" height=\"" << num(height)
    << "\" viewBox=\"0 0 " << num(f.width_px) << " " << num(height) << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
    << "<rect x=\"0\" y=\"0\" width=\"" << num(f.width_px) << "\" height=\"" << num(height) << "\" fill=\"white\"/>\n"
    << "<text x=\"" << num(f.width_px / 2) << "\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">" << esc(f.title)
    << "</text>\n";
  std::size_t colour = 0;
  for (std::size_t pi = 0; pi < f.panels.size(); ++pi) {
    const Panel& p = f.panels[pi];
    const double top = kTop + static_cast<double>(pi) * (f.panel_height_px + kGap);
    const double bottom = top + f.panel_height_px;
    std::vector<const Series*> left, right;
    for (const auto& s : p.series) (s.right_axis ? right : left).push_back(&s);
    const Range yl = range_of(left.empty() ? right : left, false, p.y.scale);
    const Range yr = right.empty() ? yl : range_of(right, false, p.y2.scale);
    auto px = [&](double x) { return kLeft + xr.frac(x) * plot_w; };
    auto py = [&](const Range& r, double y) { return bottom - r.frac(y) * f.panel_height_px; };
    const std::string clip = "clip" + std::to_string(pi);
    o << "<g class=\"panel\">\n<clipPath id=\"" << clip << "\"><rect x=\"" << num(kLeft) << "\" y=\"" << num(top)
      << "\" width=\"" << num(plot_w) << "\" height=\"" << num(f.panel_height_px) << "\"/></clipPath>\n";
    o << "<rect x=\"" << num(kLeft) << "\" y=\"" << num(top) << "\" width=\"" << num(plot_w) << "\" height=\""
      << num(f.panel_height_px) << "\" fill=\"none\" stroke=\"black\"/>\n";
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
      const double xt = f.width_px - 14;
      o << "<text class=\"axis-title\" x=\"" << num(xt) << "\" y=\"" << num(mid)
        << "\" text-anchor=\"middle\" transform=\"rotate(90 " << num(xt) << " " << num(mid) << ")\">"
        << esc(p.y2.title) << "</text>\n";
    }
    // Series: one path, a new sub-path after every unplottable point.
    double legend_y = top + 16;
    for (const auto& s : p.series) {
      const std::string color = s.color.empty() ? kPalette[colour++ % kPalette.size()] : s.color;
      const Range& r = s.right_axis ? yr : yl;
      const Scale ys = s.right_axis ? p.y2.scale : p.y.scale;
      std::string d;
      bool pen_down = false;
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!plottable(s.x[i], f.x.scale) || !plottable(s.y[i], ys)) {
          pen_down = false;
          continue;
        }
        d += (pen_down ? " L" : " M") + num(px(s.x[i])) + " " + num(py(r, s.y[i]));
        pen_down = true;
      }
      o << "<path class=\"series\" clip-path=\"url(#" << clip << ")\" fill=\"none\" stroke=\"" << esc(color)
        << "\" stroke-width=\"1.5\"" << (s.dashed ? " stroke-dasharray=\"6 4\"" : "") << " d=\"" << d.substr(1)
        << "\"/>\n";
      const double lx = kLeft + 10;
      o << "<line x1=\"" << num(lx) << "\" y1=\"" << num(legend_y - 4) << "\" x2=\"" << num(lx + 24) << "\" y2=\""
        << num(legend_y - 4) << "\" stroke=\"" << esc(color) << "\" stroke-width=\"2\""
        << (s.dashed ? " stroke-dasharray=\"6 4\"" : "") << "/>\n"
        << "<text class=\"legend\" x=\"" << num(lx + 30) << "\" y=\"" << num(legend_y) << "\">" << esc(s.label)
        << (s.right_axis ? " (right axis)" : "") << "</text>\n";
      legend_y += 16;
    }
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
