// The fit's report: text for people, JSON for machines, with the same
// content.
#include "fit/fit_internal.h"

#include <common/errors.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

namespace muscle::fit
{
namespace
{
using detail::fmt;
using detail::inf;

std::string name_list(const std::vector<std::pair<std::string, double>>& c)
{
  std::string out;
  for (const auto& [name, v] : c)
  {
    if (!out.empty())
      out += ' ';
    out += fmt("%+.2f ", v);
    out += name;
  }
  return out;
}
} // namespace

std::string Identifiability::text() const
{
  std::ostringstream out;
  out << "identifiability (Jacobian at the solution, columns scaled by |p|):\n";
  if (!singular_values.empty())
  {
    out << "  singular values (relative change of the curves per relative change of the "
           "parameters):\n   ";
    for (double s : singular_values)
      out << " " << fmt("%.2e", s);
    out << "\n";
  }
  if (all_determined())
    out << "  all free parameters are determined by the data\n";
  for (const std::string& name : no_influence)
    out << "  WARNING: " << name
        << " is not determined: it has no influence on these data (value kept at its "
           "start value)\n";
  for (std::size_t j = 0; j < names.size(); ++j)
    if (std::find(uncertain.begin(), uncertain.end(), names[j]) != uncertain.end())
      out << "  WARNING: " << names[j] << " is not determined by the scatter of these data: "
          << "its standard error " << fmt("%.3g", std_error[j])
          << " exceeds its value\n";
  for (const Combination& c : weak)
  {
    if (c.components.size() == 1)
      out << "  WARNING: " << c.components.front().first << " is "
          << (c.determined ? "poorly determined" : "not determined") << " by these data"
          << " (singular value " << fmt("%.1e", c.singular_value) << ")\n";
    else
      out << "  WARNING: the combination " << name_list(c.components)
          << " (relative changes) is "
          << (c.determined ? "poorly determined" : "not determined")
          << " (singular value " << fmt("%.1e", c.singular_value)
          << "): the data fix only the other combinations of these parameters\n";
  }
  if (!all_determined())
    out << "  (fix the flagged parameters with --fix or add load cases that depend on them)\n";
  return out.str();
}

std::string report_text(const FitResult& r)
{
  std::ostringstream out;
  const ParameterSet& p = r.fitted;
  out << "model " << to_string(p.model()) << ": " << r.residuals.size() << " data points, "
      << r.free.size() << " free parameters\n";
  out << "solver (Ceres, trust region LM, bounds): " << (r.converged ? "converged" : "NOT converged")
      << " after " << r.iterations << " iterations: " << r.termination << "\n";
  out << "cost 1/2 sum w r^2: " << fmt("%.6g", r.initial_cost) << " -> " << fmt("%.6g", r.cost)
      << "\n\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-12s %14s %14s %10s  %s\n", "parameter", "start", "fitted",
                "std.error", "");
  out << line;
  for (const std::string& name : p.names())
  {
    const auto it = std::find(r.free.begin(), r.free.end(), name);
    if (it == r.free.end())
      continue;
    const std::size_t j = it - r.free.begin();
    const double se = r.identifiability.std_error.empty() ? inf
                                                          : r.identifiability.std_error[j];
    const auto flagged = r.identifiability.flagged();
    std::string note;
    if (std::find(flagged.begin(), flagged.end(), name) != flagged.end())
      note += " not (well) determined";
    if (std::find(r.at_bound.begin(), r.at_bound.end(), name) != r.at_bound.end())
      note += " at a bound";
    std::snprintf(line, sizeof line, "%-12s %14.7g %14.7g %10s %s\n", name.c_str(),
                  r.start[name], p[name], std::isfinite(se) ? fmt("%.3g", se).c_str() : "-",
                  note.c_str());
    out << line;
  }
  std::vector<std::string> fixed;
  for (const std::string& name : p.names())
    if (std::find(r.free.begin(), r.free.end(), name) == r.free.end())
    {
      if (name == "P_opt" and uses_twitch_train(p.model()) and !p.explicitly_set("P_opt"))
        out << "P_opt = " << fmt("%.7g", p[name])
            << " follows N_a and the twitch parameters (tetanic level)\n";
      else
        fixed.push_back(name);
    }
  out << "fixed: " << join(fixed) << "\n\n";
  std::snprintf(line, sizeof line, "%-16s %6s %8s %8s %8s %8s\n", "curve", "points", "weight",
                "eps_inf", "eps_1", "eps_2");
  out << "errors of P_exact against the data (paper appendix \"Error measures\"):\n" << line;
  for (const CurveErrors& e : r.errors)
  {
    std::snprintf(line, sizeof line, "%-16s %6zu %8.3g %8.4f %8.4f %8.4f\n",
                  to_string(e.key).c_str(), e.points, e.weight, e.errors.eps_inf,
                  e.errors.eps_1, e.errors.eps_2);
    out << line;
  }
  out << "\n" << r.identifiability.text();
  return out.str();
}

std::string report_json(const FitResult& r)
{
  nlohmann::json j;
  j["model"] = to_string(r.fitted.model());
  j["converged"] = r.converged;
  j["iterations"] = r.iterations;
  j["termination"] = r.termination;
  j["cost"] = r.cost;
  j["initial_cost"] = r.initial_cost;
  j["free"] = r.free;
  j["at_bound"] = r.at_bound;
  for (const std::string& name : r.fitted.names())
  {
    j["parameters"][name] = r.fitted[name];
    j["start"][name] = r.start[name];
  }
  for (std::size_t k = 0; k < r.free.size(); ++k)
  {
    const double se = r.identifiability.std_error[k];
    j["std_error"][r.free[k]] = std::isfinite(se) ? nlohmann::json(se) : nullptr;
  }
  for (const CurveErrors& e : r.errors)
    j["errors"].push_back({{"case", to_string(e.key.load_case)},
                           {"state", to_string(e.key.state)},
                           {"points", e.points},
                           {"weight", e.weight},
                           {"eps_inf", e.errors.eps_inf},
                           {"eps_1", e.errors.eps_1},
                           {"eps_2", e.errors.eps_2}});
  const Identifiability& id = r.identifiability;
  j["identifiability"]["all_determined"] = id.all_determined();
  j["identifiability"]["singular_values"] = id.singular_values;
  j["identifiability"]["no_influence"] = id.no_influence;
  j["identifiability"]["uncertain"] = id.uncertain;
  j["identifiability"]["flagged"] = id.flagged();
  j["identifiability"]["weak_combinations"] = nlohmann::json::array();
  for (const auto& c : id.weak)
  {
    nlohmann::json cj;
    cj["singular_value"] = c.singular_value;
    cj["determined"] = c.determined;
    for (const auto& [name, v] : c.components)
      cj["components"][name] = v;
    j["identifiability"]["weak_combinations"].push_back(cj);
  }
  return j.dump(2) + "\n";
}

} // namespace muscle::fit
