// The SVG plot writer's honesty about its axis range. GIVEN a plot whose y
// range is fixed, WHEN points lie outside it, THEN they are not drawn and
// the note under the plot says how many (no point is clipped silently);
// AND shaded x ranges are drawn under the series.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "io/svg_plot.hpp"

namespace feedid::test {
namespace {

host::PlotSpec three_points(double y_max) {
  host::PlotSpec p;
  p.x = {"x", false};
  p.y = {"y", false, 0.0, y_max};
  host::PlotSeries s;
  s.x = {0.0, 1.0, 2.0};
  s.y = {0.5, 1.5, 3.0};
  p.series.push_back(s);
  return p;
}

TEST(SvgPlot, PointsOutsideAFixedRangeAreCountedInTheNote) {
  EXPECT_EQ(host::points_outside(three_points(1.0)), 2u);
  EXPECT_NE(host::render_svg(three_points(1.0)).find("2 points lie outside the axis range and are not drawn"),
            std::string::npos);
  EXPECT_EQ(host::points_outside(three_points(5.0)), 0u);
  EXPECT_EQ(host::render_svg(three_points(5.0)).find("outside the axis range"), std::string::npos);
  host::PlotSpec free = three_points(1.0);
  free.y.max = std::numeric_limits<double>::quiet_NaN();  // ranged from the data: nothing outside
  EXPECT_EQ(host::points_outside(free), 0u);
}

TEST(SvgPlot, ShadedRangesAreDrawnWithTheirLabels) {
  host::PlotSpec p = three_points(5.0);
  p.x_bands = {{0.5, 1.0, "window one"}, {1.5, 1.8, ""}};
  const std::string svg = host::render_svg(p);
  std::size_t n = 0;
  for (std::size_t at = svg.find("fill=\"#ffd54f\""); at != std::string::npos; at = svg.find("fill=\"#ffd54f\"", at + 1)) ++n;
  EXPECT_EQ(n, 2u);
  EXPECT_NE(svg.find("window one"), std::string::npos);
}

}  // namespace
}  // namespace feedid::test
