#include "loadcases/curve.h"

#include "common/errors.h"

#include <fstream>
#include <iomanip>

namespace muscle
{

std::vector<CurveRow> load_case_curve(const ParameterSet& parameters,
                                      MuscleState state, LoadCase load_case,
                                      const std::vector<double>& controls,
                                      const std::optional<CubeOptions>& fe)
{
  MaterialPointModel model(parameters);
  model.set_time_factor(state == MuscleState::active ? 1.0 : 0.0);

  std::vector<CurveRow> rows;
  for (double s : controls)
  {
    if (load_case != LoadCase::SAF and !(s > 0))
      throw InputError("stretch " + std::to_string(s) + " for " + to_string(load_case)
                       + ": stretches must be positive");
    CurveRow row;
    row.control = s;
    row.exact = exact_response(model, load_case, s).stress;
    row.paper = paper_response(parameters, load_case, state, s);
    rows.push_back(row);
  }
  if (fe)
  {
    CubeLoadCase cube(parameters, state, load_case, *fe);
    const std::vector<CubeResult> results = cube.solve(controls);
    for (std::size_t i = 0; i < rows.size(); ++i)
    {
      if (results[i].converged)
        rows[i].fe = results[i].stress;
      rows[i].fe_volume_ratio = results[i].volume_ratio;
      rows[i].fe_message = results[i].message;
    }
  }
  return rows;
}

void write_curve_csv(const std::string& path, const std::vector<CurveRow>& rows)
{
  std::ofstream out(path);
  if (!out)
    throw InputError("cannot write " + path);
  out << "stretch,P_exact,P_paper,P_fe\n" << std::setprecision(12);
  for (const CurveRow& r : rows)
  {
    out << r.control << "," << r.exact << ",";
    if (r.paper)
      out << *r.paper;
    out << ",";
    if (r.fe)
      out << *r.fe;
    out << "\n";
  }
}

} // namespace muscle
