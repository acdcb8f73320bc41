// MATLAB .mat input (host_sim/io/mat_trace.cpp): variables chosen by name like
// CSV columns, row or column vectors, v5 and v7.3 files, the CSV reader's
// row rules, and EMPS read from its .mat giving what its CSV gives.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <matio.h>

#include "identify/identify.hpp"
#include "io/trace_files.hpp"

namespace feedid::host {
namespace {

struct Var {
  std::string name;
  std::vector<double> values;
  bool row = false;  ///< 1 x n instead of n x 1
};

/// Writes the variables as doubles to a .mat file of the given version.
std::string write_mat(const std::string& stem, const std::vector<Var>& vars, mat_ft version = MAT_FT_MAT5,
                      matio_compression compression = MAT_COMPRESSION_NONE) {
  const std::string path = ::testing::TempDir() + "feedid_" + stem + ".mat";
  std::remove(path.c_str());
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, version);
  EXPECT_NE(mat, nullptr);
  for (const Var& v : vars) {
    std::vector<double> data = v.values;
    size_t dims[2] = {v.row ? 1 : data.size(), v.row ? data.size() : 1};
    matvar_t* mv = Mat_VarCreate(v.name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, data.data(), 0);
    EXPECT_EQ(Mat_VarWrite(mat, mv, compression), 0);
    Mat_VarFree(mv);
  }
  Mat_Close(mat);
  return path;
}

CsvColumns named(const char* t, const char* x, const char* u) {
  CsvColumns c;
  c.time = t;
  c.position = x;
  c.velocity = "";
  c.force = u;
  return c;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(MatTrace, RowAndColumnVectorsInV5AndV73) {
  for (const mat_ft version : {MAT_FT_MAT5, MAT_FT_MAT73}) {
    // GIVEN time as a row vector, position and force as column vectors
    const std::string path = write_mat(version == MAT_FT_MAT5 ? "v5" : "v73",
                                       {{"time", {0.0, 0.001, 0.002}, true}, {"pos", {0.0, 1e-6, 3e-6}}, {"F", {1.0, 2.0, 4.0}}},
                                       version);
    // WHEN read by name, with a force scale
    CsvColumns c = named("time", "pos", "F");
    c.force_scale = 2.0;
    const CsvResult r = read_trace_file(path, c);
    // THEN every element is a row, scaled as the CSV reader scales
    ASSERT_TRUE(r.ok) << r.error;
    ASSERT_EQ(r.trace.samples.size(), 3u);
    EXPECT_TRUE(r.trace.has_position);
    EXPECT_FALSE(r.trace.has_velocity);
    EXPECT_DOUBLE_EQ(r.trace.samples[2].t_s, 0.002);
    EXPECT_DOUBLE_EQ(r.trace.samples[2].x_m, 3e-6);
    EXPECT_DOUBLE_EQ(r.trace.samples[2].u_N, 8.0);
  }
}

TEST(MatTrace, BadAndRepeatedElementsFollowTheCsvRules) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> t, x, u;
  for (int k = 0; k < 300; ++k) {
    t.push_back(1e-3 * k);
    x.push_back(1e-6 * k);
    u.push_back(k);
  }
  x[100] = nan;                         // one bad element: skipped and named
  t[201] = t[200], x[201] = x[200], u[201] = u[200];  // a repeated sample: counted apart
  t[250] = 1e6;                         // one time stamp far ahead: that element skipped, not those after it
  const std::string path = write_mat("rules", {{"t", t}, {"x", x}, {"u", u}});
  const CsvResult r = read_trace_file(path, named("t", "x", "u"));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.trace.samples.size(), 297u);
  EXPECT_EQ(r.trace.rows_skipped, 2u);
  EXPECT_EQ(r.trace.rows_repeated, 1u);
  ASSERT_EQ(r.trace.skipped_rows.size(), 2u);
  EXPECT_TRUE(contains(r.trace.skipped_rows.front(), "element 101")) << r.trace.skipped_rows.front();
  EXPECT_TRUE(contains(r.trace.skipped_rows.back(), "ahead of the rows around it")) << r.trace.skipped_rows.back();
  for (const TraceSample& k : r.trace.samples) EXPECT_NE(k.u_N, 250.0);

  CsvColumns strict = named("t", "x", "u");
  strict.skip_bad_rows = false;
  const CsvResult s = read_trace_file(path, strict);
  EXPECT_FALSE(s.ok);
  EXPECT_TRUE(contains(s.error, "element 101")) << s.error;
}

TEST(MatTrace, ErrorsNameTheVariableAndListTheFile) {
  const std::string path = write_mat("errors", {{"t", {0.0, 1.0}}, {"x", {0.0, 1.0}}, {"u", {0.0, 1.0, 2.0}}});
  const CsvResult missing = read_trace_file(path, named("t", "x", "force"));
  EXPECT_FALSE(missing.ok);
  EXPECT_TRUE(contains(missing.error, "'force'")) << missing.error;
  EXPECT_TRUE(contains(missing.error, "the file has: 't', 'x', 'u'")) << missing.error;

  const CsvResult lengths = read_trace_file(path, named("t", "x", "u"));
  EXPECT_FALSE(lengths.ok);
  EXPECT_TRUE(contains(lengths.error, "differ in length")) << lengths.error;

  const std::string not_mat = ::testing::TempDir() + "feedid_not_a.mat";
  std::ofstream(not_mat) << "t,x,u\n0,0,0\n";
  const CsvResult bad = read_trace_file(not_mat, named("t", "x", "u"));
  EXPECT_FALSE(bad.ok);
  EXPECT_TRUE(contains(bad.error, "cannot open as a MATLAB file")) << bad.error;
}

// GIVEN a .mat whose last variable is cut short (the file truncated in its
// data), THEN the error names that variable and the truncation (libmatio
// read it silently, the missing quarter whatever memory held).
TEST(MatTrace, ATruncatedFileNamesTheDamageNotAMissingVariable) {
  std::vector<double> ramp(4000);
  for (std::size_t k = 0; k < ramp.size(); ++k) ramp[k] = 1e-3 * static_cast<double>(k);
  const std::string path = write_mat("truncated", {{"t", ramp}, {"x", ramp}, {"u", ramp}});
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  bytes.resize(bytes.size() - 8 * 1000);  // a quarter of u's data gone
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  const CsvResult r = read_trace_file(path, named("t", "x", "u"));
  ASSERT_FALSE(r.ok) << "read " << r.trace.samples.size() << " samples of a truncated file";
  EXPECT_TRUE(contains(r.error, "variable 'u' runs past the end of the file")) << r.error;
  EXPECT_TRUE(contains(r.error, "truncated")) << r.error;

  // Compressed, likewise (libmatio inflated what there was and said nothing).
  std::vector<double> noise(4000);
  for (std::size_t k = 0; k < noise.size(); ++k) noise[k] = std::sin(0.37 * static_cast<double>(k * k));
  const std::string zipped = write_mat("truncated_zlib", {{"t", ramp}, {"x", ramp}, {"u", noise}}, MAT_FT_MAT5,
                                       MAT_COMPRESSION_ZLIB);
  std::ifstream zin(zipped, std::ios::binary);
  std::string zbytes((std::istreambuf_iterator<char>(zin)), std::istreambuf_iterator<char>());
  zbytes.resize(zbytes.size() - 4000);
  std::ofstream(zipped, std::ios::binary | std::ios::trunc) << zbytes;
  const CsvResult z = read_trace_file(zipped, named("t", "x", "u"));
  ASSERT_FALSE(z.ok);
  EXPECT_TRUE(contains(z.error, "variable 'u' runs past the end of the file")) << z.error;
}

TEST(MatTrace, MatrixIsRefused) {
  const std::string path = ::testing::TempDir() + "feedid_matrix.mat";
  std::remove(path.c_str());
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  std::vector<double> d(6, 1.0);
  size_t dims[2] = {2, 3};
  matvar_t* mv = Mat_VarCreate("t", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, d.data(), 0);
  Mat_VarWrite(mat, mv, MAT_COMPRESSION_NONE);
  Mat_VarFree(mv);
  Mat_Close(mat);
  const CsvResult r = read_trace_file(path, named("t", "t", "t"));
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.error, "one row or one column")) << r.error;
  EXPECT_TRUE(contains(r.error, "a 2x3 matrix")) << r.error;
}

TEST(MatTrace, EmpsFromMatEqualsEmpsFromCsv) {
  const std::string dir = std::string(FEEDID_SHARED_DIR) + "/data/emps";
  if (!std::ifstream(dir + "/DATA_EMPS.mat")) GTEST_SKIP() << "EMPS data not found at " << dir;
  // The CSV's force_N is gtau * vir (data/emps/README.md); the .mat holds vir.
  CsvColumns mat_cols = named("t", "qm", "vir");
  mat_cols.force_scale = 35.15065188248547;
  const CsvResult m = read_trace_file(dir + "/DATA_EMPS.mat", mat_cols);
  const CsvResult c = read_trace_file(dir + "/DATA_EMPS.csv", named("t_s", "qm_m", "force_N"));
  ASSERT_TRUE(m.ok) << m.error;
  ASSERT_TRUE(c.ok) << c.error;
  ASSERT_EQ(m.trace.samples.size(), c.trace.samples.size());
  const IdentifyResult a = identify(m.trace, IdentifyOptions{});
  const IdentifyResult b = identify(c.trace, IdentifyOptions{});
  ASSERT_TRUE(a.error.empty() && b.error.empty()) << a.error << b.error;
  // The CSV was written with 17 digits: the same doubles, the same result.
  EXPECT_EQ(a.estimate.mass_kg, b.estimate.mass_kg);
  EXPECT_EQ(a.estimate.pos.coulomb_N, b.estimate.pos.coulomb_N);
  EXPECT_EQ(a.estimate.neg.viscous_Ns_m, b.estimate.neg.viscous_Ns_m);
  EXPECT_NEAR(a.estimate.mass_kg, 95.0, 1.0);
}

}  // namespace
}  // namespace feedid::host

namespace feedid::host {
namespace {

/// A double matrix `rows` x `cols` from column-major data, unnamed for a
/// struct field when name is null.
matvar_t* matrix(const char* name, std::size_t rows, std::size_t cols, std::vector<double> data) {
  size_t dims[2] = {rows, cols};
  return Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, data.data(), 0);
}

const std::vector<double> kT = {0.0, 0.001, 0.002}, kX = {0.0, 1e-6, 3e-6}, kU = {1.0, 2.0, 4.0};

/// A file as recorders write them: `rec` a struct with fields act_pos, F
/// and a nested struct meta.time; `data` an n x 3 matrix (t, x, u by
/// column); `rows` its 3 x n transpose (t, x, u by row).
std::string write_structured(mat_ft version) {
  const std::string path = ::testing::TempDir() + "feedid_struct" + (version == MAT_FT_MAT73 ? "73" : "5") + ".mat";
  std::remove(path.c_str());
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, version);
  size_t one[2] = {1, 1};
  const char* meta_fields[] = {"time"};
  matvar_t* meta = Mat_VarCreateStruct("meta", 2, one, meta_fields, 1);
  Mat_VarSetStructFieldByName(meta, "time", 0, matrix(nullptr, 3, 1, kT));
  const char* rec_fields[] = {"act_pos", "F", "meta"};
  matvar_t* rec = Mat_VarCreateStruct("rec", 2, one, rec_fields, 3);
  Mat_VarSetStructFieldByName(rec, "act_pos", 0, matrix(nullptr, 1, 3, kX));
  Mat_VarSetStructFieldByName(rec, "F", 0, matrix(nullptr, 3, 1, kU));
  Mat_VarSetStructFieldByName(rec, "meta", 0, meta);
  std::vector<double> by_column, by_row;
  for (const auto* v : {&kT, &kX, &kU}) by_column.insert(by_column.end(), v->begin(), v->end());
  for (std::size_t k = 0; k < 3; ++k)
    for (const auto* v : {&kT, &kX, &kU}) by_row.push_back((*v)[k]);
  matvar_t* data = matrix("data", 3, 3, by_column);
  matvar_t* rows = matrix("rows", 3, 3, by_row);
  for (matvar_t* v : {rec, data, rows}) {
    EXPECT_EQ(Mat_VarWrite(mat, v, MAT_COMPRESSION_NONE), 0);
    Mat_VarFree(v);
  }
  Mat_Close(mat);
  return path;
}

// GIVEN a v5 and a v7.3 file holding the signals as struct fields (one of
// them nested), as columns of a matrix and as rows of one, THEN each name
// form reads the same rows; a name of a field, column or row the file does
// not have is an error naming it and what is there.
TEST(MatTrace, StructFieldsAndMatrixColumnsAndRows) {
  for (const mat_ft version : {MAT_FT_MAT5, MAT_FT_MAT73}) {
    const std::string path = write_structured(version);
    for (const CsvColumns& c : {named("rec.meta.time", "rec.act_pos", "rec.F"), named("data(:,1)", "data:2", "data(:, 3)"),
                                named("rows(1,:)", "rows(2,:)", "rows(3,:)")}) {
      const CsvResult r = read_trace_file(path, c);
      ASSERT_TRUE(r.ok) << c.time << ": " << r.error;
      ASSERT_EQ(r.trace.samples.size(), 3u) << c.time;
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(r.trace.samples[k].t_s, kT[k]) << c.time;
        EXPECT_EQ(r.trace.samples[k].x_m, kX[k]) << c.time;
        EXPECT_EQ(r.trace.samples[k].u_N, kU[k]) << c.time;
      }
    }
    const struct {
      CsvColumns c;
      const char* says;
    } bad[] = {
        {named("rec.meta.time", "rec.pos", "rec.F"), "no field 'pos' in struct 'rec'; it has: 'act_pos', 'F', 'meta'"},
        {named("rec.meta", "rec.act_pos", "rec.F"), "'rec.meta' is a struct: name one of its fields (rec.meta.FIELD); it has: 'time'"},
        {named("data(:,1)", "data(:,4)", "data(:,3)"), "variable 'data(:,4)' (position) is not a real vector (a 3x3 array has no column 4)"},
        {named("data(:,1)", "data.x", "data(:,3)"), "'data' is not a struct (a 3x3 array), so it has no field 'x'"},
        {named("data", "data:2", "data:3"), "a 3x3 matrix: one row or one column expected; a column of it is data(:,2) or data:2"},
        {named("data(:,0)", "data:2", "data:3"), "variable 'data(:,0)' (time) is not a .mat name"},
        {named("data(1,2)", "data:2", "data:3"), "is not a .mat name"},
        {named("data(:,1)", "data:2", "nothere.x"), "no variable 'nothere' (force); the file has: '"},
    };
    for (const auto& b : bad) {
      const CsvResult r = read_trace_file(path, b.c);
      EXPECT_FALSE(r.ok) << b.says;
      EXPECT_TRUE(contains(r.error, path + ": ")) << r.error;
      EXPECT_TRUE(contains(r.error, b.says)) << r.error;
    }
  }
}

// GIVEN a .mat log, THEN the stream monitor reads (open_trace_stream) hands
// on the rows the whole-file reader gives, and a .mat it cannot read is its
// error at open.
TEST(MatTrace, StreamedLikeTheWholeFile) {
  const std::string path = write_structured(MAT_FT_MAT5);
  const CsvColumns c = named("data(:,1)", "data:2", "data:3");
  CsvStream st = open_trace_stream(path, c);
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_TRUE(st.has_position());
  std::vector<TraceSample> rows;
  TraceSample s;
  while (st.next(s)) rows.push_back(s);
  EXPECT_TRUE(st.error().empty()) << st.error();
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(rows[k].x_m, kX[k]);
  CsvStream missing = open_trace_stream(path, named("data(:,1)", "data:2", "F"));
  EXPECT_FALSE(missing.ok());
  EXPECT_TRUE(contains(missing.error(), "no variable 'F' (force)")) << missing.error();
}

}  // namespace
}  // namespace feedid::host
