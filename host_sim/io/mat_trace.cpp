// Reading traces from MATLAB .mat files with libmatio. Host only.
#include "mat_trace.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include <matio.h>

#include "column_trace.hpp"
#include "trace_rows.hpp"

namespace feedid::host {
namespace {

struct MatClose {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct VarFree {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatFile = std::unique_ptr<mat_t, MatClose>;
using MatVar = std::unique_ptr<matvar_t, VarFree>;

/// Names of the variables in the file, for an error message.
std::string variable_list(const std::string& path) {
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  std::string names;
  if (!mat) return names;
  while (MatVar v{Mat_VarReadNextInfo(mat.get())}) names += (names.empty() ? "" : ", ") + std::string(v->name ? v->name : "?");
  return names;
}

template <typename T> void copy_as_double(const void* data, std::size_t n, std::vector<double>& out) {
  const T* p = static_cast<const T*>(data);
  out.assign(p, p + n);
}

/// The variable as doubles, or an error naming why it is not a vector.
bool read_vector(mat_t* mat, const std::string& path, const std::string& name, const char* role, std::vector<double>& out,
                 std::string& error) {
  MatVar v(Mat_VarRead(mat, name.c_str()));
  if (!v) {
    error = path + ": no variable '" + name + "' (" + role + "); the file has: " + variable_list(path);
    return false;
  }
  std::size_t n = 1, longest = 0;
  for (int d = 0; d < v->rank; ++d) {
    n *= v->dims[d];
    longest = std::max(longest, v->dims[d]);
  }
  if (v->isComplex || v->data == nullptr || n != longest) {
    error = path + ": variable '" + name + "' (" + role + ") is not a real vector" +
            (v->isComplex ? " (complex)" : n != longest ? " (a matrix: one row or one column expected)" : " (empty)");
    return false;
  }
  switch (v->class_type) {
    case MAT_C_DOUBLE: copy_as_double<double>(v->data, n, out); return true;
    case MAT_C_SINGLE: copy_as_double<float>(v->data, n, out); return true;
    case MAT_C_INT8: copy_as_double<std::int8_t>(v->data, n, out); return true;
    case MAT_C_UINT8: copy_as_double<std::uint8_t>(v->data, n, out); return true;
    case MAT_C_INT16: copy_as_double<std::int16_t>(v->data, n, out); return true;
    case MAT_C_UINT16: copy_as_double<std::uint16_t>(v->data, n, out); return true;
    case MAT_C_INT32: copy_as_double<std::int32_t>(v->data, n, out); return true;
    case MAT_C_UINT32: copy_as_double<std::uint32_t>(v->data, n, out); return true;
    case MAT_C_INT64: copy_as_double<std::int64_t>(v->data, n, out); return true;
    case MAT_C_UINT64: copy_as_double<std::uint64_t>(v->data, n, out); return true;
    default:
      error = path + ": variable '" + name + "' (" + role + ") is not numeric (MATLAB class " +
              std::to_string(static_cast<int>(v->class_type)) + ")";
      return false;
  }
}

bool has_variable(mat_t* mat, const std::string& name) {
  if (name.empty()) return false;
  MatVar v(Mat_VarReadInfo(mat, name.c_str()));
  return v != nullptr;
}

}  // namespace

CsvResult read_trace_mat(const std::string& path, const CsvColumns& columns) {
  CsvResult result;
  result.trace.source = path;
  result.error = scale_error(columns);
  if (!result.error.empty()) return result;
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) {
    result.error = path + ": cannot open as a MATLAB file (missing, unreadable, or not a v4/v5/v7.3 .mat)";
    return result;
  }
  const bool has_position = has_variable(mat.get(), columns.position);
  const bool has_velocity = has_variable(mat.get(), columns.velocity);
  if (!has_position && !has_velocity) {
    result.error = path + ": no variable '" + columns.position + "' (position) and no '" + columns.velocity +
                   "' (velocity); need at least one; the file has: " + variable_list(path);
    return result;
  }
  TraceColumns c;
  if (!read_vector(mat.get(), path, columns.time, "time", c.t, result.error) ||
      !read_vector(mat.get(), path, columns.force, "force", c.u, result.error) ||
      (has_position && !read_vector(mat.get(), path, columns.position, "position", c.x, result.error)) ||
      (has_velocity && !read_vector(mat.get(), path, columns.velocity, "velocity", c.v, result.error)))
    return result;
  return trace_from_columns(c, columns, path, 1);  // MATLAB counts from 1
}

}  // namespace feedid::host
