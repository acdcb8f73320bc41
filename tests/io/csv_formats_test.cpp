// The CSV formats loggers write (host_sim/io/csv_table.hpp): `;` and tab
// separators with decimal commas, comment and metadata lines before the
// header, headerless files with --columns, ISO 8601 time stamps. Each is
// read by the whole-file and the streamed reader alike (one rule), and a
// file that cannot be read names file:line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "io/csv_trace.hpp"
#include "io/message_text.hpp"
#include "io/time_stamp.hpp"
#include "io/trace_files.hpp"

namespace feedid::host {
namespace {

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
}

std::string write_text(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "feedid_fmt_" + name + ".csv";
  std::ofstream f(path, std::ios::binary);
  f << text;
  return path;
}

/// Reads `path` whole and streamed; expects both to agree row for row, in
/// their counts and notes, and returns the whole-file result.
CsvResult read_both(const std::string& path, const CsvColumns& cols) {
  const CsvResult whole = read_trace_csv(path, cols);
  CsvStream st(path, cols);
  std::vector<TraceSample> rows;
  TraceSample s;
  while (st.next(s)) rows.push_back(s);
  if (!whole.ok) {
    EXPECT_EQ(st.error(), whole.error) << "the same words, at open or at the row";
    return whole;
  }
  EXPECT_TRUE(st.error().empty()) << st.error();
  EXPECT_EQ(st.notes(), whole.trace.notes);
  EXPECT_EQ(st.time_unit_stated(), whole.trace.time_unit_stated);
  EXPECT_EQ(st.rows_skipped(), whole.trace.rows_skipped);
  EXPECT_EQ(st.has_position(), whole.trace.has_position);
  EXPECT_EQ(rows.size(), whole.trace.samples.size());
  for (std::size_t k = 0; k < rows.size() && k < whole.trace.samples.size(); ++k) {
    EXPECT_EQ(rows[k].t_s, whole.trace.samples[k].t_s) << k;
    EXPECT_EQ(rows[k].x_m, whole.trace.samples[k].x_m) << k;
    EXPECT_EQ(rows[k].u_N, whole.trace.samples[k].u_N) << k;
  }
  return whole;
}

/// The same three rows as plain comma-separated text.
const char* const kPlain = "t,x,u\n0,0,1.5\n0.001,1e-06,2.25\n0.002,2.5e-06,-3.125\n";

void expect_same_as_plain(const CsvResult& r) {
  ASSERT_TRUE(r.ok) << r.error;
  const CsvResult plain = read_trace_csv(write_text("plain", kPlain), CsvColumns{});
  ASSERT_TRUE(plain.ok) << plain.error;
  ASSERT_EQ(r.trace.samples.size(), plain.trace.samples.size());
  for (std::size_t k = 0; k < plain.trace.samples.size(); ++k) {
    EXPECT_EQ(r.trace.samples[k].t_s, plain.trace.samples[k].t_s) << k;
    EXPECT_EQ(r.trace.samples[k].x_m, plain.trace.samples[k].x_m) << k;
    EXPECT_EQ(r.trace.samples[k].u_N, plain.trace.samples[k].u_N) << k;
  }
}

// GIVEN the rows of a comma-separated log written as a German spreadsheet
// exports them (`;` with decimal commas) and as tab-separated text (with
// commas and with points), THEN each reads to the same numbers bit for bit.
TEST(CsvFormats, SemicolonAndTabWithDecimalCommasReadAsThePlainFile) {
  expect_same_as_plain(read_both(write_text("semicolon",
                                            "t;x;u\n0;0;1,5\n0,001;1E-06;2,25\n0,002;2,5e-06;-3,125\n"),
                                 CsvColumns{}));
  expect_same_as_plain(read_both(write_text("tab_comma", "t\tx\tu\r\n0\t0\t1,5\r\n0,001\t1e-06\t2,25\r\n0,002\t2,5e-06\t-3,125\r\n"),
                                 CsvColumns{}));
  expect_same_as_plain(read_both(write_text("tab_point", "t\tx\tu\n0\t0\t1.5\n0.001\t1e-06\t2.25\n0.002\t2.5e-06\t-3.125\n"),
                                 CsvColumns{}));
}

// GIVEN a `;` file whose force column's name holds a comma, THEN the
// separator is the one under which the header has the named columns (the
// first comma in a header made it a comma file).
TEST(CsvFormats, SeparatorIsTheOneThatGivesTheNamedColumns) {
  CsvColumns cols;
  cols.force = "Kraft, N";
  const CsvResult r = read_both(write_text("name_comma", "t;x;Kraft, N\n0;0;1,5\n0,001;1e-06;2,25\n0,002;2,5e-06;-3,125\n"), cols);
  expect_same_as_plain(r);
}

// GIVEN a decimal comma in a comma-separated file's row (two fields where
// one was meant), THEN the row is a bad row naming its line, not a number
// misread.
TEST(CsvFormats, ACommaFileDoesNotTakeDecimalCommas) {
  CsvColumns strict;
  strict.skip_bad_rows = false;
  const std::string path = write_text("comma_mixed", "t,x,u\n0,0,1\n0,001,0,2\n");
  const CsvResult r = read_both(path, strict);
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.error, path + ":3: expected 3 fields, found 4")) << r.error;
}

// GIVEN a logger's preamble before the header: a comment, `key: value`
// lines, a `key,value` line and a blank line, THEN they are left out,
// counted and the first named in a note; the rows are the plain file's.
TEST(CsvFormats, MetadataLinesBeforeTheHeaderAreCountedAndLeftOut) {
  const std::string path = write_text("preamble", std::string("# exported by DriveLog 2.1\nAxis: X\nSample rate,1000 Hz\n\n") + kPlain);
  const CsvResult r = read_both(path, CsvColumns{});
  expect_same_as_plain(r);
  ASSERT_EQ(r.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(r.trace.notes[0], path + ": 3 lines before the header (line 5) left out")) << r.trace.notes[0];
  EXPECT_TRUE(contains(r.trace.notes[0], "line 1: '# exported by DriveLog 2.1'")) << r.trace.notes[0];
  EXPECT_TRUE(read_trace_csv(write_text("no_preamble", kPlain), CsvColumns{}).trace.notes.empty());
}

// GIVEN metadata lines and then a header that lacks the force column, THEN
// the error names the header's line and what it has, not the first line.
TEST(CsvFormats, AWrongNameAfterMetadataIsSaidAtTheHeader) {
  const std::string path = write_text("preamble_missing", "# log\nDate: 2026-11-25\nt,x,force\n0,0,1\n0.001,0,1\n");
  const CsvResult r = read_both(path, CsvColumns{});
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.error, path + ":3: missing column 'u' (force); header has: 't', 'x', 'force'")) << r.error;
  const std::string comments = write_text("only_comments", "# a\n# b\n");
  EXPECT_TRUE(contains(read_both(comments, CsvColumns{}).error, "no header row")) << comments;
}

// GIVEN a file without a header row, THEN without --columns the error
// names line 1 and --columns; with --columns the fields are named by
// position (an empty name leaves a column unread), lines before the first
// data row (here a header of other names) are counted, and a row count
// that does not match is an error naming the line and both counts.
TEST(CsvFormats, HeaderlessFilesNameTheirColumnsWithColumns) {
  const std::string bare = write_text("headerless", "0,0,1.5\n0.001,1e-06,2.25\n0.002,2.5e-06,-3.125\n");
  const CsvResult refused = read_both(bare, CsvColumns{});
  EXPECT_FALSE(refused.ok);
  EXPECT_TRUE(contains(refused.error, bare + ":1: no header row names the columns")) << refused.error;
  EXPECT_TRUE(contains(refused.error, "--columns t,x,u")) << refused.error;

  CsvColumns cols;
  cols.names_by_position = names_by_position("t, x ,u");
  expect_same_as_plain(read_both(bare, cols));

  cols.names_by_position = names_by_position("t,,x,u");
  const std::string extra = write_text("headerless_extra", "Zeit;Status;Pos;Kraft\n0;7;0;1,5\n0,001;7;1e-06;2,25\n0,002;8;2,5e-06;-3,125\n");
  const CsvResult r = read_both(extra, cols);
  expect_same_as_plain(r);
  ASSERT_EQ(r.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(r.trace.notes[0], "1 line before the first data row (line 2)")) << r.trace.notes[0];

  cols.names_by_position = names_by_position("t,x,u,v");
  const CsvResult count = read_both(bare, cols);
  EXPECT_FALSE(count.ok);
  EXPECT_TRUE(contains(count.error, bare + ":1: a data row of 3 fields, and --columns names 4")) << count.error;

  cols.names_by_position = names_by_position("t,t,u");
  EXPECT_TRUE(contains(read_both(bare, cols).error, "--columns: column 't' (time) appears more than once"));
}

// GIVEN a list of recordings (--in-list) where one headerless file names
// its columns with the key `columns`, THEN it is read with those names and
// the other file with its header.
TEST(CsvFormats, InListTakesColumnsPerFile) {
  const std::string bare = write_text("list_bare", "0,0,1.5\n0.001,1e-06,2.25\n0.002,2.5e-06,-3.125\n");
  const std::string plain = write_text("list_plain", kPlain);
  const std::string list = write_text("list", bare + " columns=t,x,u\n" + plain + "\n");
  std::vector<TraceInput> inputs;
  std::string error;
  ASSERT_TRUE(read_input_list(list, CsvColumns{}, inputs, error)) << error;
  ASSERT_EQ(inputs.size(), 2u);
  EXPECT_EQ(inputs[0].columns.names_by_position, (std::vector<std::string>{"t", "x", "u"}));
  EXPECT_TRUE(inputs[1].columns.names_by_position.empty());
  const CsvResult r = read_trace_files(inputs);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.trace.samples.size(), 6u);
}

TEST(TimeStamp, Iso8601FormsAndRanges) {
  IsoTime a, b;
  ASSERT_TRUE(parse_iso8601("2026-11-25T12:00:00Z", false, a));
  EXPECT_EQ(a.seconds, 1795608000);  // date -u -d 2026-11-25T12:00:00Z +%s
  EXPECT_EQ(a.fraction, 0.0);
  for (const char* same : {"2026-11-25T13:00:00+01:00", "2026-11-25 12:00:00", "2026-11-25t07:00:00-0500",
                           "2026-11-25T12:00:00z", "2026-11-25T14:00:00+02"}) {
    ASSERT_TRUE(parse_iso8601(same, false, b)) << same;
    EXPECT_EQ(b.seconds, a.seconds) << same;
  }
  ASSERT_TRUE(parse_iso8601("2026-11-25T12:00:00.123456Z", false, b));
  EXPECT_EQ(b.fraction, 0.123456);
  ASSERT_TRUE(parse_iso8601("2026-11-25T12:00:00,5", true, b));
  EXPECT_EQ(b.fraction, 0.5);
  ASSERT_TRUE(parse_iso8601("2028-02-29T00:00:00Z", false, b));  // a leap day
  ASSERT_TRUE(parse_iso8601("2026-03-01T00:00:00Z", false, a));
  ASSERT_TRUE(parse_iso8601("2026-02-28T23:59:59.75Z", false, b));
  EXPECT_EQ(seconds_between(b, a), 0.25);
  for (const char* bad : {"2026-11-25T12:00:00,5", "2026-02-29T00:00:00Z", "2026-11-25T24:00:00Z", "2026-13-01T00:00:00Z",
                          "2026-11-25T12:00Z", "2026-11-25T12:00:00.Z", "2026-11-25T12:00:00Zx", "2026-11-25",
                          "2026-11-25T12:00:00+25:00", "1.5", "", "2026-11-25X12:00:00"})
    EXPECT_FALSE(parse_iso8601(bad, false, b)) << bad;
}

// GIVEN ISO 8601 stamps in the time column (UTC, an offset, a space
// separator, across midnight), THEN the time is seconds since the first
// row's stamp, exact to the stamp's digits, the unit counts as stated and a
// note says so; a row whose stamp is not one is a bad row naming its line.
TEST(CsvFormats, Iso8601TimeStampsAreSecondsSinceTheFirstRow) {
  const std::string path = write_text("iso", "t,x,u\n2026-11-30T23:59:59.999Z,0,1.5\n2026-12-01T01:00:00.000+01:00,1e-06,2.25\n"
                                             "2026-12-01 00:00:00.001,2.5e-06,-3.125\n");
  const CsvResult r = read_both(path, CsvColumns{});
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.trace.samples.size(), 3u);
  EXPECT_EQ(r.trace.samples[0].t_s, 0.0);
  EXPECT_NEAR(r.trace.samples[1].t_s, 0.001, 1e-15);
  EXPECT_NEAR(r.trace.samples[2].t_s, 0.002, 1e-15);
  EXPECT_TRUE(r.trace.time_unit_stated);
  ASSERT_EQ(r.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(r.trace.notes[0], "read as ISO 8601 time stamps, in seconds since the first row's '2026-11-30T23:59:59.999Z'"));

  const std::string semi = write_text("iso_semicolon", "Zeit;x;u\n2026-11-25 12:00:00,000;0;1,5\n2026-11-25 12:00:00,001;1e-06;2,25\n");
  CsvColumns german;
  german.time = "Zeit";
  const CsvResult g = read_both(semi, german);
  ASSERT_TRUE(g.ok) << g.error;
  EXPECT_EQ(g.trace.samples[1].t_s, 0.001);

  // AND a comment line between the header and the first stamp is a bad row,
  // and the stamps after it are read as ISO 8601 all the same
  CsvColumns lenient;
  lenient.max_bad_row_share = 0.5;
  const CsvResult c = read_both(write_text("iso_comment", "t,x,u\n# logging started\n2026-11-30T23:59:59.999Z,0,1.5\n"
                                                          "2026-12-01T00:00:00.000Z,1e-06,2.25\n"), lenient);
  ASSERT_TRUE(c.ok) << c.error;
  ASSERT_EQ(c.trace.samples.size(), 2u);
  EXPECT_EQ(c.trace.rows_skipped, 1u);
  EXPECT_NEAR(c.trace.samples[1].t_s, 0.001, 1e-15);
  EXPECT_TRUE(c.trace.time_unit_stated);
  ASSERT_EQ(c.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(c.trace.notes[0], "read as ISO 8601 time stamps"));

  CsvColumns strict;
  strict.skip_bad_rows = false;
  const std::string mixed = write_text("iso_mixed", "t,x,u\n2026-11-25T12:00:00Z,0,1\n0.001,0,1\n");
  const CsvResult m = read_both(mixed, strict);
  EXPECT_FALSE(m.ok);
  EXPECT_TRUE(contains(m.error, mixed + ":3: column 't': '0.001' is not an ISO 8601 time stamp like the first row's"))
      << m.error;
}

// GIVEN the plain log's rows stamped with Unix time (1700000000.001 s), in
// seconds with points, with decimal commas, and in ms since the epoch,
// THEN the time is counted from the first row's whole part digit by digit:
// bit for bit the plain log's time (a double of 1.7e9 s keeps only 2.4e-7 s
// of a stamp, which moved identify's choices and diagnose's verdict), and a
// note names the origin. A stamp before the origin is out of order and said so.
TEST(CsvFormats, UnixTimeStampsAreCountedFromTheFirstRowsWholePart) {
  const std::string unix_s = write_text("unix_s", "t,x,u\n1700000000,0,1.5\n1700000000.001,1e-06,2.25\n1700000000.002,2.5e-06,-3.125\n");
  const CsvResult r = read_both(unix_s, CsvColumns{});
  expect_same_as_plain(r);
  ASSERT_EQ(r.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(r.trace.notes[0], "time column 't' counted from 1700000000 (its first stamp's whole part"));
  EXPECT_TRUE(contains(r.trace.notes[0], "keeps them to 1.2e-07 s"));

  CsvColumns comma;
  comma.time = "t";
  expect_same_as_plain(read_both(write_text("unix_comma", "t;x;u\n1700000000;0;1,5\n1700000000,001;1e-06;2,25\n1700000000,002;2,5e-06;-3,125\n"), comma));

  CsvColumns ms;
  ms.time = "t_ms";
  const CsvResult m = read_both(write_text("unix_ms", "t_ms,x,u\n1700000000000,0,1.5\n1700000000001,1e-06,2.25\n1700000000002.5,2.5e-06,-3.125\n"), ms);
  ASSERT_TRUE(m.ok) << m.error;
  ASSERT_EQ(m.trace.samples.size(), 3u);
  EXPECT_EQ(m.trace.samples[1].t_s, 1.0 * 1e-3);
  EXPECT_EQ(m.trace.samples[2].t_s, 2.5 * 1e-3);

  EXPECT_EQ(r.trace.time_origin_s, 1700000000.0);
  EXPECT_EQ(m.trace.time_origin_s, 1700000000.0);
  // AND tab- or ;-separated with points, nanoseconds since the epoch (19
  // digits), a '+', a fraction padded past 200 digits, and a first row
  // whose stamp does not read (the origin is the first stamp that does)
  expect_same_as_plain(read_both(write_text("unix_tab", "t\tx\tu\n1700000000\t0\t1.5\n1700000000.001\t1e-06\t2.25\n1700000000.002\t2.5e-06\t-3.125\n"), CsvColumns{}));
  CsvColumns ns;
  ns.time = "t_ns";
  const CsvResult n = read_both(write_text("unix_ns", "t_ns,x,u\n1700000000000000000,0,1.5\n1700000000001000000,1e-06,2.25\n+1700000000002000000." + std::string(300, '0') + ",2.5e-06,-3.125\n"), ns);
  expect_same_as_plain(n);
  EXPECT_EQ(n.trace.time_origin_s, 1.7e9);
  CsvColumns lenient;
  lenient.max_bad_row_share = 0.5;
  const CsvResult late = read_both(write_text("unix_late", "t,x,u\nabc,0,1\n1700000000,0,1.5\n1700000000.001,1e-06,2.25\n1700000000.002,2.5e-06,-3.125\n"), lenient);
  expect_same_as_plain(late);
  EXPECT_EQ(late.trace.rows_skipped, 1u);
  ASSERT_EQ(late.trace.notes.size(), 1u);
  EXPECT_TRUE(contains(late.trace.notes[0], "counted from 1700000000"));
  // AND pooled with a log of another origin, each run keeps its own and the
  // pool states none (its times count from neither)
  const CsvResult pooled = read_trace_files({{write_text("plain_pool", kPlain), CsvColumns{}}, {unix_s, CsvColumns{}}});
  ASSERT_TRUE(pooled.ok) << pooled.error;
  ASSERT_EQ(pooled.trace.runs.size(), 2u);
  EXPECT_EQ(pooled.trace.runs[0].time_origin_s, 0.0);
  EXPECT_EQ(pooled.trace.runs[1].time_origin_s, 1.7e9);
  EXPECT_TRUE(std::isnan(pooled.trace.time_origin_s));
  // AND a log that starts near zero has no origin (its stamps as logged)
  EXPECT_EQ(read_both(write_text("plain_origin", kPlain), CsvColumns{}).trace.time_origin_s, 0.0);

  const std::string back = write_text("unix_back", "t,x,u\n1700000000.5,0,1\n1699999999.75,0,1\n1700000000.501,0,1\n");
  const CsvResult b = read_both(back, CsvColumns{});
  EXPECT_FALSE(b.ok);
  EXPECT_TRUE(contains(b.error, back + ":3: column 't': time '1699999999.75' is not greater than previous '1700000000.5'")) << b.error;
}

// GIVEN any of these formats' messages, THEN they are printable and bounded.
TEST(CsvFormats, NotesArePrintableAndBounded) {
  const std::string path = write_text("junk_preamble", "\x1b[2J" + std::string(5000, '\xff') + "\nt,x,u\n0,0,1\n");
  const CsvResult r = read_both(path, CsvColumns{});
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.trace.notes.size(), 1u);
  EXPECT_TRUE(is_bounded_printable(r.trace.notes[0])) << r.trace.notes[0];
}

}  // namespace
}  // namespace feedid::host

namespace feedid::host {
namespace {

// GIVEN numbers written every way a logger or a hand may write them, THEN
// each reads to the value strtod gives, bit for bit: the reader's fast
// path (from_chars) and its fallback (strtod) agree, and what only strtod
// takes (a leading '+', hex, a denormal) still reads.
TEST(CsvNumbers, EveryWrittenFormReadsAsStrtodReadsIt) {
  const std::vector<std::string> forms = {"1.5",     "+1.5",   "-0.25",  ".5",     "5.",      "1e3",
                                          "1E-3",    "-2.5e+2", "0x1p3",  "1e-310", "123456789.123456789",
                                          "0.1",     "7",      "-0",     "3.14159265358979323846"};
  std::string text = "t,x,u\n";
  for (std::size_t i = 0; i < forms.size(); ++i)
    text += std::to_string(i) + "," + std::to_string(i) + "," + forms[i] + "\n";
  CsvColumns cols;
  cols.velocity.clear();
  const CsvResult r = parse_trace_csv(text, "forms.csv", cols);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.trace.samples.size(), forms.size());
  for (std::size_t i = 0; i < forms.size(); ++i)
    EXPECT_EQ(r.trace.samples[i].u_N, std::strtod(forms[i].c_str(), nullptr)) << forms[i];
}

}  // namespace
}  // namespace feedid::host
