// Reading traces from MATLAB .mat files with libmatio. Host only.
#include "mat_trace.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include <matio.h>

#include "column_trace.hpp"
#include "message_text.hpp"
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

/// Names of the variables in the file, for an error message (quoted and
/// bounded: a corrupt file's names can be any bytes).
std::string variable_list(const std::string& path) {
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  std::vector<std::string> names;
  if (!mat) return "";
  while (names.size() <= kListedNames) {
    MatVar v{Mat_VarReadNextInfo(mat.get())};
    if (!v) break;
    names.emplace_back(v->name ? v->name : "?");
  }
  return names.empty() ? "no readable variable" : name_list(names);
}

/// "2x3", the dimensions of a variable.
std::string dims_text(const matvar_t& v) {
  std::string s;
  for (int d = 0; d < v.rank; ++d) s += (d ? "x" : "") + std::to_string(v.dims[d]);
  return s;
}

/// The message for variable `name` cut short by the end of the file.
std::string cut_short(const std::string& path, const std::string& name, std::uintmax_t need, std::uintmax_t have) {
  return path + ": variable " + quoted_text(name) + " runs past the end of the file (it ends at byte " +
         std::to_string(need) + ", the file has " + std::to_string(have) + "): the file is truncated";
}

/// Where the k-th element of a v5 file ends, walking its 8-byte tags (type
/// 14 matrix or 15 compressed, then the byte count) from byte 128, in the
/// byte order that reads a valid first type; 0 when the walk stops short of
/// element k or the tags are not v5's (then libmatio judges the file).
std::vector<std::uintmax_t> v5_element_ends(const std::string& path, std::uintmax_t file_bytes) {
  std::vector<std::uintmax_t> ends;
  std::ifstream f(path, std::ios::binary);
  std::uintmax_t pos = 128;
  int swap = -1;
  unsigned char tag[8];
  while (pos + 8 <= file_bytes && f.seekg(static_cast<std::streamoff>(pos)) && f.read(reinterpret_cast<char*>(tag), 8)) {
    auto u32 = [&](const unsigned char* b, bool big) {
      return big ? (std::uint32_t{b[0]} << 24 | std::uint32_t{b[1]} << 16 | std::uint32_t{b[2]} << 8 | b[3])
                 : (std::uint32_t{b[3]} << 24 | std::uint32_t{b[2]} << 16 | std::uint32_t{b[1]} << 8 | b[0]);
    };
    if (swap < 0) swap = (u32(tag, false) == 14 || u32(tag, false) == 15) ? 0 : 1;
    const std::uint32_t type = u32(tag, swap == 1);
    if (type != 14 && type != 15) break;
    pos += 8 + std::uintmax_t{u32(tag + 4, swap == 1)};
    ends.push_back(pos);
  }
  return ends;
}

/// "" or which variable a truncated v4/v5 file cuts short. libmatio reads a
/// variable past the end of the file without a word, compressed or not
/// (the rest of its buffer is whatever memory held), so each variable's
/// extent is checked against the file's size: v5 by its element tag, v4
/// (never compressed) by the data sizes its headers declare. HDF5 (v7.3)
/// checks its own.
std::string truncated_variable(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (ec || !mat || Mat_GetVersion(mat.get()) == MAT_FT_MAT73) return "";
  std::vector<std::string> names;
  std::uintmax_t declared = 0;
  const bool v4 = Mat_GetVersion(mat.get()) == MAT_FT_MAT4;
  while (MatVar v{Mat_VarReadNextInfo(mat.get())}) {
    names.emplace_back(v->name ? v->name : "?");
    declared += Mat_VarGetSize(v.get());
    if (v4 && declared > file_bytes) return cut_short(path, names.back(), declared, file_bytes);
  }
  if (v4) return "";
  const std::vector<std::uintmax_t> ends = v5_element_ends(path, file_bytes);
  for (std::size_t k = 0; k < ends.size(); ++k)
    if (ends[k] > file_bytes)
      return cut_short(path, k < names.size() ? names[k] : "number " + std::to_string(k + 1), ends[k], file_bytes);
  return "";
}

bool has_variable(mat_t* mat, const std::string& name) {
  if (name.empty()) return false;
  MatVar v(Mat_VarReadInfo(mat, name.c_str()));
  return v != nullptr;
}

/// The 1-based index in `text` (digits only, > 0), or 0.
std::size_t index_of(const std::string& text) {
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos) return 0;
  return static_cast<std::size_t>(std::stoul(text));
}

}  // namespace

bool parse_mat_name(const std::string& text, MatName& out) {
  out = MatName{};
  std::string rest = text;
  const std::size_t open = rest.rfind('(');
  if (!rest.empty() && rest.back() == ')' && open != std::string::npos) {
    std::string inside = rest.substr(open + 1, rest.size() - open - 2);
    inside.erase(std::remove(inside.begin(), inside.end(), ' '), inside.end());  // data(:, 2) as MATLAB takes it
    const std::size_t comma = inside.find(',');
    if (comma == std::string::npos) return false;
    const std::string a = inside.substr(0, comma), b = inside.substr(comma + 1);
    out.column = a == ":" ? index_of(b) : 0;
    out.row = b == ":" ? index_of(a) : 0;
    if (out.column == 0 && out.row == 0) return false;
    rest.resize(open);
  } else if (const std::size_t colon = rest.rfind(':'); colon != std::string::npos) {
    out.column = index_of(rest.substr(colon + 1));
    if (out.column == 0) return false;
    rest.resize(colon);
  }
  std::size_t from = 0;
  for (;;) {
    const std::size_t dot = rest.find('.', from);
    const std::string part = rest.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    if (part.empty() || part.find_first_of("():,") != std::string::npos) return false;
    (from == 0 ? out.variable : out.fields.emplace_back()) = part;
    if (dot == std::string::npos) return true;
    from = dot + 1;
  }
}

namespace {

/// The struct field `name` selects in `v` (read whole), or null with `error`
/// naming where the path breaks and the fields there are.
matvar_t* select_field(matvar_t* v, const MatName& name, const std::string& at, std::string& error) {
  std::string walked = name.variable;
  auto field_names = [](matvar_t* st) {
    std::vector<std::string> fields;
    char* const* names = Mat_VarGetStructFieldnames(st);
    for (unsigned i = 0; names != nullptr && i < Mat_VarGetNumberOfFields(st) && i <= kListedNames; ++i)
      fields.emplace_back(names[i] ? names[i] : "?");
    return name_list(fields);
  };
  for (std::size_t k = 0; k <= name.fields.size(); ++k) {
    if (k == name.fields.size()) {
      if (v->class_type == MAT_C_STRUCT)
        error = at + quoted_text(walked) + " is a struct: name one of its fields (" + walked + ".FIELD); it has: " +
                field_names(v);
      return v->class_type == MAT_C_STRUCT ? nullptr : v;
    }
    const std::string& field = name.fields[k];
    if (v->class_type != MAT_C_STRUCT) {
      error = at + quoted_text(walked) + " is not a struct (a " + dims_text(*v) + " array), so it has no field " +
              quoted_text(field);
      return nullptr;
    }
    std::size_t n = 1;
    for (int d = 0; d < v->rank; ++d) n *= v->dims[d];
    if (n != 1) {
      error = at + quoted_text(walked) + " is a " + dims_text(*v) + " struct array: one struct expected";
      return nullptr;
    }
    matvar_t* f = Mat_VarGetStructFieldByName(v, field.c_str(), 0);
    if (f == nullptr) {
      error = at + "no field " + quoted_text(field) + " in struct " + quoted_text(walked) + "; it has: " + field_names(v);
      return nullptr;
    }
    v = f;
    walked += "." + field;
  }
  return v;
}

template <typename T> void copy_as_double(const void* data, std::size_t first, std::size_t stride, std::size_t n,
                                          std::vector<double>& out) {
  const T* p = static_cast<const T*>(data) + first;
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(p[i * stride]);
}

/// Where the selected elements lie in `v`'s data (column-major): a column
/// or row of a matrix, or a whole vector; false with `why` otherwise.
bool selection(const matvar_t& v, const MatName& name, std::size_t& first, std::size_t& stride, std::size_t& n,
               std::string& why) {
  std::size_t total = 1, longest = 0;
  for (int d = 0; d < v.rank; ++d) {
    total *= v.dims[d];
    longest = std::max(longest, v.dims[d]);
  }
  const std::size_t rows = v.rank >= 1 ? v.dims[0] : 0, cols = v.rank == 2 ? v.dims[1] : 0;
  first = 0;
  stride = 1;
  n = total;
  if (name.column == 0 && name.row == 0) {
    if (total != longest)
      why = " (a " + dims_text(v) + " matrix: one row or one column expected; a column of it is " + name.variable +
            "(:,2) or " + name.variable + ":2, a row " + name.variable + "(2,:))";
    return why.empty();
  }
  if (v.rank != 2 || (name.column > cols) || (name.row > rows)) {
    why = " (a " + dims_text(v) + " array has no " +
          (name.column ? "column " + std::to_string(name.column) : "row " + std::to_string(name.row)) + ")";
    return false;
  }
  first = name.column ? (name.column - 1) * rows : name.row - 1;
  stride = name.column ? 1 : rows;
  n = name.column ? rows : cols;
  return true;
}

/// The variable (or its field, column or row) as doubles, or an error
/// naming why it is not a vector.
bool read_vector(mat_t* mat, const std::string& path, const std::string& spec, const char* role, std::vector<double>& out,
                 std::string& error) {
  const std::string var = "variable " + quoted_text(spec) + " (" + role + ")";
  MatName name;
  if (!parse_mat_name(spec, name)) {
    error = path + ": " + var + " is not a .mat name: a variable, a struct field (rec.act_pos), a matrix column "
                                "(data(:,2) or data:2) or row (data(2,:))";
    return false;
  }
  MatVar root(Mat_VarRead(mat, name.variable.c_str()));
  if (!root) {
    // Listed but unreadable is a damaged file, not a missing name.
    error = has_variable(mat, name.variable)
                ? path + ": " + var + " is in the file but its data cannot be read (the file is truncated or corrupt)"
                : path + ": no variable " + quoted_text(name.variable) + " (" + role + "); the file has: " + variable_list(path);
    return false;
  }
  const matvar_t* v = select_field(root.get(), name, path + ": " + var + ": ", error);
  if (v == nullptr) return false;
  std::size_t first = 0, stride = 1, n = 0;
  std::string why;
  if (v->isComplex || v->data == nullptr || !selection(*v, name, first, stride, n, why)) {
    error = path + ": " + var + " is not a real vector" +
            (v->isComplex         ? " (complex)"
             : !why.empty()       ? why
             : v->data == nullptr ? " (" + dims_text(*v) + ", no data: empty, or its data cannot be read)"
                                  : std::string(" (empty)"));
    return false;
  }
  switch (v->class_type) {
    case MAT_C_DOUBLE: copy_as_double<double>(v->data, first, stride, n, out); return true;
    case MAT_C_SINGLE: copy_as_double<float>(v->data, first, stride, n, out); return true;
    case MAT_C_INT8: copy_as_double<std::int8_t>(v->data, first, stride, n, out); return true;
    case MAT_C_UINT8: copy_as_double<std::uint8_t>(v->data, first, stride, n, out); return true;
    case MAT_C_INT16: copy_as_double<std::int16_t>(v->data, first, stride, n, out); return true;
    case MAT_C_UINT16: copy_as_double<std::uint16_t>(v->data, first, stride, n, out); return true;
    case MAT_C_INT32: copy_as_double<std::int32_t>(v->data, first, stride, n, out); return true;
    case MAT_C_UINT32: copy_as_double<std::uint32_t>(v->data, first, stride, n, out); return true;
    case MAT_C_INT64: copy_as_double<std::int64_t>(v->data, first, stride, n, out); return true;
    case MAT_C_UINT64: copy_as_double<std::uint64_t>(v->data, first, stride, n, out); return true;
    default:
      error = path + ": " + var + " is not numeric (MATLAB class " + std::to_string(static_cast<int>(v->class_type)) + ")";
      return false;
  }
}

}  // namespace

CsvResult read_trace_mat(const std::string& path, const CsvColumns& columns) {
  CsvResult result;
  result.trace.source = path;
  result.error = scale_error(columns);
  if (result.error.empty() && columns.rate_hz > 0)
    result.error = path + ": --rate serves CSV logs without a time column; a .mat log names its time variable (--time)";
  if (!result.error.empty()) return result;
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) {
    result.error = path + ": cannot open as a MATLAB file (missing, unreadable, or not a v4/v5/v7.3 .mat)";
    return result;
  }
  result.error = truncated_variable(path);
  if (!result.error.empty()) return result;
  // Present when its variable is: a wrong field or column of it is then
  // said by read_vector, not taken as a signal not logged.
  MatName position, velocity;
  const bool has_position = parse_mat_name(columns.position, position) && has_variable(mat.get(), position.variable);
  const bool has_velocity = parse_mat_name(columns.velocity, velocity) && has_variable(mat.get(), velocity.variable);
  if (!has_position && !has_velocity) {
    result.error = path + ": no variable " + quoted_text(columns.position) + " (position) and no " +
                   quoted_text(columns.velocity) + " (velocity); need at least one; the file has: " + variable_list(path);
    return result;
  }
  if (const std::string missing = named_column_missing(columns, has_position, has_velocity); !missing.empty()) {
    result.error = path + ": " + missing + "; the file has: " + variable_list(path);
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
