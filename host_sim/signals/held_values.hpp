// Columns logged faster than they are updated. A robot loop that logs every
// 5 ms the last status frame its motor controller sent every 20 ms holds
// each position for four rows and then jumps: the differences are zero
// three rows in four and four times the motion's in the fourth, and any
// derivative of the column is mostly that sawtooth. Host only.
#pragma once
#include <cstddef>
#include <vector>

namespace feedid::host {

/// Rows each value of a column stands for (1: it changes every row).
struct HoldPattern {
  int period_rows = 1;
  std::size_t changes = 0;  ///< changes of value the period was read from
};

/// The hold period of column y: the commonest number of rows between
/// changes of value, counted only at changes larger than min_change (on a
/// position, a few encoder counts: a slow axis holds its count for a
/// varying number of rows without any hold in the logger). A period of 2
/// or more, kept by at least three in four of at least 20 such changes
/// (to within a row of jitter), is a hold; anything else is 1.
HoldPattern detect_hold(const std::vector<double>& y, double min_change);

/// y with each held value spread over its hold: between two rows where the
/// value changed, at most `max_rows` apart and with no time step over
/// max_step_s between them, the rows in between are interpolated linearly
/// in time, each new value taken at the row where it first appears.
/// Longer stretches of one value (rest) and the rows before the first and
/// after the last change are left as logged.
void spread_held_values(std::vector<double>& y, const std::vector<double>& t, int max_rows, double max_step_s);

}  // namespace feedid::host
