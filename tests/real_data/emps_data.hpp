// Where the EMPS data lies and how its CSV columns read (../shared/data/emps/README.md),
// for every test on it.
#pragma once
#include <string>

#include "io/csv_trace.hpp"

namespace feedid::test {

inline const std::string emps_dir = std::string(FEEDID_SHARED_DIR) + "/data/emps";

/// Time, motor position and force; no velocity column (it is derived from position).
inline host::CsvColumns emps_columns() {
  host::CsvColumns c;
  c.time = "t_s";
  c.position = "qm_m";
  c.velocity = "";  // not read
  c.force = "force_N";
  return c;
}

}  // namespace feedid::test
