#include "svg_plot.hpp"
#include "output_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace feedid::host {
namespace {

const char* const kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string num(double v, int prec = 4) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*g", prec, v);
  return b;
}

bool usable(double v, bool log) { return std::isfinite(v) && (!log || v > 0.0); }

/// Axis after ranging: data range [lo, hi] (in log10 units on a log axis)
/// and the tick positions with their labels.
struct Scale {
  bool log = false;
  double lo = 0, hi = 1;  ///< in axis units (log10 of the value on a log axis)
  std::vector<double> major, minor;  ///< in axis units
  std::vector<std::string> labels;   ///< SVG text content for each major tick
  double to_axis(double v) const { return log ? std::log10(v) : v; }
};

double nice_step(double span, int target) {
  const double raw = span / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / p;
  return (f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0) * p;
}

Scale make_scale(const PlotAxis& ax, const std::vector<double>& data) {
  Scale s;
  s.log = ax.log;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double v : data)
    if (usable(v, ax.log)) { lo = std::min(lo, v); hi = std::max(hi, v); }
  if (usable(ax.min, ax.log)) lo = ax.min;
  if (usable(ax.max, ax.log)) hi = ax.max;
  if (!(lo <= hi)) { lo = ax.log ? 1.0 : 0.0; hi = ax.log ? 10.0 : 1.0; }
  if (ax.log) {
    double a = std::log10(lo), b = std::log10(hi);
    if (!usable(ax.min, true)) a = std::floor(a + 1e-9);
    if (!usable(ax.max, true)) b = std::ceil(b - 1e-9);
    if (b <= a) { a -= 0.5; b += 0.5; }
    s.lo = a;
    s.hi = b;
    const int k0 = static_cast<int>(std::ceil(a - 1e-9)), k1 = static_cast<int>(std::floor(b + 1e-9));
    const int every = k1 - k0 > 8 ? 2 : 1;
    for (int k = k0; k <= k1; ++k) {
      if ((k - k0) % every != 0) { s.minor.push_back(k); continue; }
      s.major.push_back(k);
      s.labels.push_back("10<tspan dy=\"-6\" font-size=\"9\">" + std::to_string(k) + "</tspan>");
    }
    for (int k = static_cast<int>(std::floor(a)); k <= k1; ++k)
      for (int m = 2; m <= 9; ++m) {
        const double t = k + std::log10(static_cast<double>(m));
        if (t > a && t < b) s.minor.push_back(t);
      }
    // Less than two labelled decades: label the 2 and 5 minors too.
    if (s.major.size() < 2)
      for (double t : std::vector<double>(s.minor))
        if (std::fabs(std::fmod(t - std::floor(t), 1.0) - std::log10(2.0)) < 1e-9 ||
            std::fabs(std::fmod(t - std::floor(t), 1.0) - std::log10(5.0)) < 1e-9) {
          s.major.push_back(t);
          s.labels.push_back(num(std::pow(10.0, t), 3));
        }
    return s;
  }
  if (hi == lo) {
    const double w = lo == 0.0 ? 1.0 : 0.1 * std::fabs(lo);
    lo -= w;
    hi += w;
  }
  const double step = nice_step(hi - lo, 5);
  if (!std::isfinite(ax.min)) lo = std::floor(lo / step + 1e-9) * step;
  if (!std::isfinite(ax.max)) hi = std::ceil(hi / step - 1e-9) * step;
  s.lo = lo;
  s.hi = hi;
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step) {
    const double v = std::fabs(t) < 1e-12 * step ? 0.0 : t;
    s.major.push_back(v);
    s.labels.push_back(num(v));
  }
  return s;
}

/// The plot area inside the canvas and the maps from axis to pixel coordinates.
struct Frame {
  Scale sx, sy;
  double W, H, left, top, pw, ph;
  bool legend_below;
  double px(double axis_x) const { return left + (axis_x - sx.lo) / (sx.hi - sx.lo) * pw; }
  double py(double axis_y) const { return top + ph - (axis_y - sy.lo) / (sy.hi - sy.lo) * ph; }
};

Frame make_frame(const PlotSpec& p) {
  std::vector<double> xs, ys;
  for (const auto& s : p.series) {
    xs.insert(xs.end(), s.x.begin(), s.x.end());
    ys.insert(ys.end(), s.y.begin(), s.y.end());
  }
  Frame f{make_scale(p.x, xs), make_scale(p.y, ys), static_cast<double>(p.width_px), static_cast<double>(p.height_px), 78, p.title.empty() ? 20.0 : 44.0, 0, 0,
          p.legend == "below"};
  const double right = 24, bottom = (p.note.empty() ? 58 : 76) + (f.legend_below ? 22 : 0);
  f.pw = f.W - f.left - right;
  f.ph = f.H - f.top - bottom;
  return f;
}

std::string series_color(const PlotSpec& p, std::size_t i) {
  const PlotSeries& s = p.series[i];
  return s.color.empty() ? kPalette[i % (sizeof kPalette / sizeof *kPalette)] : s.color;
}

/// Canvas, clip path and title.
void write_canvas(std::ostringstream& o, const PlotSpec& p, const Frame& f) {
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << f.W << "\" height=\"" << f.H << "\" viewBox=\"0 0 "
    << f.W << " " << f.H << "\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<defs><clipPath id=\"" << escape(p.id) << "\"><rect x=\"" << f.left << "\" y=\"" << f.top << "\" width=\""
    << f.pw << "\" height=\"" << f.ph << "\"/></clipPath></defs>\n";
  if (!p.title.empty())
    o << "<text x=\"" << f.W / 2 << "\" y=\"26\" text-anchor=\"middle\" font-size=\"15\" font-weight=\"bold\">"
      << escape(p.title) << "</text>\n";
}

/// The shaded x ranges, clipped to the plot area, with their labels.
void write_bands(std::ostringstream& o, const PlotSpec& p, const Frame& f) {
  for (const PlotBand& b : p.x_bands) {
    if (!usable(b.x0, p.x.log) || !usable(b.x1, p.x.log)) continue;
    const double a = std::clamp(f.px(f.sx.to_axis(b.x0)), f.left, f.left + f.pw);
    const double z = std::clamp(f.px(f.sx.to_axis(b.x1)), f.left, f.left + f.pw);
    if (z <= a) continue;
    o << "<rect x=\"" << num(a, 6) << "\" y=\"" << f.top << "\" width=\"" << num(z - a, 6) << "\" height=\"" << f.ph
      << "\" fill=\"#ffd54f\" fill-opacity=\"0.35\"/>\n";
    // A band in the right half is labelled from its right edge, so the text stays inside the plot.
    const bool right = a > f.left + f.pw / 2;
    if (!b.label.empty())
      o << "<text x=\"" << num(right ? z - 3 : a + 3, 6) << "\" y=\"" << f.top + 12 << "\" font-size=\"10\" fill=\"#7a5c00\""
        << (right ? " text-anchor=\"end\"" : "") << ">" << escape(b.label) << "</text>\n";
  }
}

/// Grid, frame, tick labels, axis labels and the note.
void write_axes(std::ostringstream& o, const PlotSpec& p, const Frame& f) {
  const double left = f.left, top = f.top, pw = f.pw, ph = f.ph;
  o << "<g stroke=\"#e4e4e4\" stroke-width=\"1\">\n";
  for (double t : f.sx.minor) o << "<line x1=\"" << num(f.px(t), 6) << "\" y1=\"" << top << "\" x2=\"" << num(f.px(t), 6) << "\" y2=\"" << top + ph << "\" stroke=\"#f2f2f2\"/>\n";
  for (double t : f.sy.minor) o << "<line x1=\"" << left << "\" y1=\"" << num(f.py(t), 6) << "\" x2=\"" << left + pw << "\" y2=\"" << num(f.py(t), 6) << "\" stroke=\"#f2f2f2\"/>\n";
  for (double t : f.sx.major) o << "<line x1=\"" << num(f.px(t), 6) << "\" y1=\"" << top << "\" x2=\"" << num(f.px(t), 6) << "\" y2=\"" << top + ph << "\"/>\n";
  for (double t : f.sy.major) o << "<line x1=\"" << left << "\" y1=\"" << num(f.py(t), 6) << "\" x2=\"" << left + pw << "\" y2=\"" << num(f.py(t), 6) << "\"/>\n";
  o << "</g>\n";
  o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
    << "\" fill=\"none\" stroke=\"#333\"/>\n";
  for (std::size_t i = 0; i < f.sx.major.size(); ++i)
    o << "<text x=\"" << num(f.px(f.sx.major[i]), 6) << "\" y=\"" << top + ph + 18 << "\" text-anchor=\"middle\">"
      << f.sx.labels[i] << "</text>\n";
  for (std::size_t i = 0; i < f.sy.major.size(); ++i)
    o << "<text x=\"" << left - 6 << "\" y=\"" << num(f.py(f.sy.major[i]) + 4, 6) << "\" text-anchor=\"end\">"
      << f.sy.labels[i] << "</text>\n";
  o << "<text x=\"" << left + pw / 2 << "\" y=\"" << top + ph + 40 << "\" text-anchor=\"middle\">"
    << escape(p.x.label) << "</text>\n";
  o << "<text transform=\"translate(18," << top + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << escape(p.y.label) << "</text>\n";
  if (!p.note.empty())
    o << "<text x=\"" << left << "\" y=\"" << f.H - 8 << "\" font-size=\"10\" fill=\"#555\">" << escape(p.note)
      << "</text>\n";
}

/// Series, clipped to the plot area; invalid points break the line.
void write_series(std::ostringstream& o, const PlotSpec& p, const Frame& f) {
  o << "<g clip-path=\"url(#" << escape(p.id) << ")\" fill=\"none\" stroke-width=\"1.8\">\n";
  for (std::size_t i = 0; i < p.series.size(); ++i) {
    const PlotSeries& s = p.series[i];
    const std::string color = series_color(p, i);
    const std::size_t n = std::min(s.x.size(), s.y.size());
    if (s.line) {
      std::string d;
      bool pen = false;
      for (std::size_t k = 0; k < n; ++k) {
        if (!usable(s.x[k], p.x.log) || !usable(s.y[k], p.y.log)) { pen = false; continue; }
        d += (pen ? " L" : " M") + num(f.px(f.sx.to_axis(s.x[k])), 6) + "," + num(f.py(f.sy.to_axis(s.y[k])), 6);
        pen = true;
      }
      if (!d.empty())
        o << "<path d=\"" << d.substr(1) << "\" stroke=\"" << color << "\""
          << (s.dashed ? " stroke-dasharray=\"6,4\"" : "") << "/>\n";
    }
    if (s.markers)
      for (std::size_t k = 0; k < n; ++k)
        if (usable(s.x[k], p.x.log) && usable(s.y[k], p.y.log))
          o << "<circle cx=\"" << num(f.px(f.sx.to_axis(s.x[k])), 6) << "\" cy=\"" << num(f.py(f.sy.to_axis(s.y[k])), 6)
            << "\" r=\"3\" fill=\"" << color << "\" stroke=\"none\"/>\n";
  }
  o << "</g>\n";
}

/// The legend of the labelled series: in a box at a corner, or in one row below the plot.
void write_legend(std::ostringstream& o, const PlotSpec& p, const Frame& f) {
  std::vector<std::size_t> shown;
  std::size_t longest = 0;
  for (std::size_t i = 0; i < p.series.size(); ++i)
    if (!p.series[i].label.empty()) { shown.push_back(i); longest = std::max(longest, p.series[i].label.size()); }
  if (shown.empty()) return;
  const bool below = f.legend_below;
  const double lw = 40 + 6.6 * static_cast<double>(longest), lh = 8 + 18.0 * static_cast<double>(shown.size());
  const bool at_right = p.legend.find("right") != std::string::npos;
  const bool at_bottom = p.legend.find("bottom") != std::string::npos;
  const double lx = at_right ? f.left + f.pw - lw - 8 : f.left + 8;
  const double ly = below ? f.top + f.ph + 46 : (at_bottom ? f.top + f.ph - lh - 8 : f.top + 8);
  o << "<g>";
  if (!below)
    o << "<rect x=\"" << lx << "\" y=\"" << ly << "\" width=\"" << num(lw, 6) << "\" height=\"" << lh
      << "\" fill=\"white\" fill-opacity=\"0.9\" stroke=\"#999\"/>";
  o << "\n";
  for (std::size_t r = 0; r < shown.size(); ++r) {
    const PlotSeries& s = p.series[shown[r]];
    const std::string color = series_color(p, shown[r]);
    // Below the plot the entries run in one row, each as wide as the longest.
    const double lx_r = below ? f.left + (lw + 10) * static_cast<double>(r) : lx;
    const double yy = below ? ly + 12 : ly + 16 + 18.0 * static_cast<double>(r);
    if (s.line)
      o << "<line x1=\"" << lx_r + 6 << "\" y1=\"" << yy - 4 << "\" x2=\"" << lx_r + 28 << "\" y2=\"" << yy - 4
        << "\" stroke=\"" << color << "\" stroke-width=\"1.8\"" << (s.dashed ? " stroke-dasharray=\"6,4\"" : "")
        << "/>\n";
    if (s.markers)
      o << "<circle cx=\"" << lx_r + 17 << "\" cy=\"" << yy - 4 << "\" r=\"3\" fill=\"" << color << "\"/>\n";
    o << "<text x=\"" << lx_r + 34 << "\" y=\"" << yy << "\">" << escape(s.label) << "</text>\n";
  }
  o << "</g>\n";
}

}  // namespace

std::size_t points_outside(const PlotSpec& p) {
  auto out = [](double v, const PlotAxis& ax) {
    return usable(v, ax.log) && ((usable(ax.min, ax.log) && v < ax.min) || (usable(ax.max, ax.log) && v > ax.max));
  };
  std::size_t n = 0;
  for (const PlotSeries& s : p.series)
    for (std::size_t k = 0; k < s.x.size() && k < s.y.size(); ++k)
      if (usable(s.x[k], p.x.log) && usable(s.y[k], p.y.log) && (out(s.x[k], p.x) || out(s.y[k], p.y))) ++n;
  return n;
}

std::string render_svg(const PlotSpec& spec) {
  PlotSpec p = spec;
  if (const std::size_t n = points_outside(spec); n > 0)
    p.note += (p.note.empty() ? "" : "; ") + std::to_string(n) +
              (n == 1 ? " point lies outside the axis range and is not drawn"
                      : " points lie outside the axis range and are not drawn");
  const Frame f = make_frame(p);
  std::ostringstream o;
  write_canvas(o, p, f);
  write_bands(o, p, f);
  write_axes(o, p, f);
  write_series(o, p, f);
  write_legend(o, p, f);
  o << "</svg>\n";
  return o.str();
}

bool write_svg(const std::string& path, const PlotSpec& spec, std::string& error) {
  error = write_whole_file(path, render_svg(spec));
  return error.empty();
}

}  // namespace feedid::host
