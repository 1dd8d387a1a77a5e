#pragma once

#include <loadcases/load_case.h>

#include <string>
#include <vector>

namespace muscle::fit
{

/// One measured point: nominal stress [kPa] of a load case and muscle state at
/// a control value (stretch; shear for SAF), with where it came from.
struct DataPoint
{
  LoadCase load_case;
  MuscleState state;
  double control; ///< stretch, or shear for SAF
  double stress;  ///< nominal stress [kPa]
  std::string file;
  int line = 0;
};

/// Read a CSV file with the header `case,state,stretch,stress` (columns in any
/// order, further columns ignored; blank lines and lines starting with '#'
/// skipped).  Every malformed row is an InputError naming file, line, column,
/// the value and what is allowed.
std::vector<DataPoint> read_data_csv(const std::string& path);

/// Write points in the same format (stress with 12 significant digits).
void write_data_csv(const std::string& path, const std::vector<DataPoint>& points);

/// A load case and state: one curve of the data.
struct CurveKey
{
  LoadCase load_case;
  MuscleState state;
  bool operator<(const CurveKey& o) const
  {
    return load_case != o.load_case ? load_case < o.load_case : state < o.state;
  }
  bool operator==(const CurveKey& o) const
  {
    return load_case == o.load_case and state == o.state;
  }
};
std::string to_string(const CurveKey& key); ///< "UTCAF passive"

/// State name with a did-you-mean suggestion on error.
MuscleState parse_state_name(const std::string& name);

} // namespace muscle::fit
