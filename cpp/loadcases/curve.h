#pragma once

#include "loadcases/cube_fe.h"
#include "loadcases/load_case.h"

#include <optional>
#include <string>
#include <vector>

namespace muscle
{

/// One row of a load-case curve: the three responses side by side.
struct CurveRow
{
  double control;              ///< stretch (shear for SAF)
  double exact;                ///< P_exact [kPa]
  std::optional<double> paper; ///< P_paper where the paper has a closed form
  std::optional<double> fe;    ///< P_fe, empty if not computed or failed
  double fe_volume_ratio = 1;
  std::string fe_message;      ///< why P_fe is missing
};

/// P_exact, P_paper and (optionally) P_fe of one model, state and load case.
std::vector<CurveRow> load_case_curve(const ParameterSet& parameters,
                                      MuscleState state, LoadCase load_case,
                                      const std::vector<double>& controls,
                                      const std::optional<CubeOptions>& fe);

/// CSV with the header stretch,P_exact,P_paper,P_fe (empty fields where a
/// response is missing).
void write_curve_csv(const std::string& path, const std::vector<CurveRow>& rows);

} // namespace muscle
