// A small SVG line-plot writer for the figures in docs/: series of (x, y)
// points on linear or logarithmic axes, with title, axis labels (units in
// the label text), ticks, grid and a legend. No dependencies. Host only.
//
//   PlotSpec p;
//   p.title = "Wall time against trace length";
//   p.x = {"trace length (samples)", true};
//   p.y = {"wall time (s)", true};
//   p.series.push_back({"streaming", xs, ys});
//   std::string err;
//   if (!write_svg("docs/figures/scaling_time.svg", p, err)) { ... }
#pragma once
#include <limits>
#include <string>
#include <vector>

namespace feedid::host {

struct PlotSeries {
  std::string label;         ///< legend text (empty: not in the legend)
  std::vector<double> x, y;  ///< points; a non-finite value (or <= 0 on a log axis) breaks the line
  std::string color;         ///< CSS colour; empty picks from a fixed palette by series index
  bool markers = true;       ///< draw a dot at each point
  bool line = true;          ///< join consecutive points
  bool dashed = false;
};

struct PlotAxis {
  std::string label;  ///< with its unit, e.g. "wall time (s)"
  bool log = false;   ///< base-10 logarithmic axis
  /// Range; NaN (the default) means from the data. On a log axis the data
  /// range is widened to whole decades.
  double min = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};

/// A shaded range of x (e.g. where a residual's energy lies), drawn under the series.
struct PlotBand {
  double x0 = 0.0, x1 = 0.0;
  std::string label;  ///< small text at the band's top (may be empty)
};

struct PlotSpec {
  std::string title;
  PlotAxis x, y;
  std::vector<PlotSeries> series;
  int width_px = 720;
  int height_px = 460;
  /// Legend corner: "top-left", "top-right", "bottom-left", "bottom-right",
  /// or "below": one row under the plot, off the data.
  std::string legend = "top-left";
  /// Id prefix of the SVG's clip path: plots inlined into one HTML page
  /// need different ones.
  std::string id = "plot";
  std::string note;  ///< optional small text under the plot (e.g. the machine)
  std::vector<PlotBand> x_bands;
};

/// Points of the spec's series that lie outside an axis range the spec
/// fixes (PlotAxis min/max): render_svg does not draw them and says how many
/// in the note, so that no point is clipped silently.
std::size_t points_outside(const PlotSpec& spec);

/// The plot as a standalone SVG document.
std::string render_svg(const PlotSpec& spec);

/// Writes render_svg(spec) to path; false (and `error` naming the file) on failure.
bool write_svg(const std::string& path, const PlotSpec& spec, std::string& error);

}  // namespace feedid::host
