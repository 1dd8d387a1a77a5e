#include "material/parameters.h"

#include "common/errors.h"
#include "material/time_functions.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

namespace muscle
{
namespace
{
/// Shortest representation that reads back to the same double.
std::string format_value(double v)
{
  for (int digits = 6; digits <= 17; ++digits)
  {
    std::ostringstream s;
    s << std::setprecision(digits) << v;
    if (std::stod(s.str()) == v)
      return s.str();
  }
  return std::to_string(v);
}

} // namespace

Model::Model(const std::string& name)
{
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  std::vector<std::string> names;
  for (const forms::LawInfo& law : forms::laws())
  {
    if (lower == law.name)
    {
      _law = &law;
      return;
    }
    names.push_back(law.name);
  }
  throw InputError("unknown model '" + name + "'" + did_you_mean(lower, names)
                   + "; laws: " + join(names)
                   + " (forms/materials/*.py and MUSCLE_MATERIALS)");
}

bool Model::active() const
{
  return std::string(_law->drive) != "none";
}

bool Model::has_activation_kernel() const
{
  return std::string(_law->drive) == "omega_kernel";
}

const std::vector<Model>& all_models()
{
  static const std::vector<Model> models = []
  {
    std::vector<Model> out;
    for (const forms::LawInfo& law : forms::laws())
      out.emplace_back(law.name);
    return out;
  }();
  return models;
}

std::vector<Model> models_for(const std::string& role)
{
  std::vector<Model> out;
  for (const forms::LawInfo& law : forms::laws())
    for (const char* r : law.default_for)
      if (role == r)
        out.emplace_back(law.name);
  return out;
}

Model default_model(const std::string& role)
{
  const std::vector<Model> models = models_for(role);
  if (models.size() != 1)
    throw std::logic_error("role '" + role + "': " + std::to_string(models.size())
                           + " laws declare DEFAULT_FOR it (one expected; "
                             "forms/muscleforms/law.py ROLES)");
  return models.front();
}

std::string to_string(const Model& model)
{
  return model.name();
}

Model parse_model(const std::string& name)
{
  return Model(name);
}

bool uses_twitch_train(const Model& model)
{
  return std::string(model.law().time_function) == "twitch_train";
}

const std::vector<ParameterSpec>& parameter_specs(const Model& model)
{
  static std::map<const forms::LawInfo*, std::vector<ParameterSpec>> specs;
  auto [it, inserted] = specs.try_emplace(&model.law());
  if (inserted)
  {
    for (const forms::ParameterInfo& p : model.law().parameters)
      it->second.push_back({p.name, p.preset, p.lower, p.upper, p.lower_open,
                            p.upper_open, p.unit, p.meaning});
  }
  return it->second;
}

ParameterSet::ParameterSet(Model model) : _model(model)
{
  for (const ParameterSpec& s : parameter_specs(model))
    _values.push_back(s.preset);
  _explicit.assign(_values.size(), false);
  update_derived();
}

std::size_t ParameterSet::index(const std::string& name) const
{
  const auto& specs = parameter_specs(_model);
  for (std::size_t i = 0; i < specs.size(); ++i)
    if (specs[i].name == name)
      return i;
  throw InputError("unknown parameter '" + name + "' for model "
                   + to_string(_model) + did_you_mean(name, names())
                   + "; parameters: " + join(names()));
}

bool ParameterSet::has(const std::string& name) const
{
  const auto& specs = parameter_specs(_model);
  return std::any_of(specs.begin(), specs.end(),
                     [&](const ParameterSpec& s) { return s.name == name; });
}

double ParameterSet::operator[](const std::string& name) const
{
  return _values[index(name)];
}

void ParameterSet::set(const std::string& name, double value)
{
  const std::size_t i = index(name);
  _values[i] = value;
  _explicit[i] = true;
  update_derived();
}

void ParameterSet::set_assignment(const std::string& assignment)
{
  const auto eq = assignment.find('=');
  if (eq == std::string::npos or eq == 0)
    throw InputError("expected NAME=VALUE, got '" + assignment + "'");
  const std::string name = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  const auto value = parse_real(text);
  if (!value)
    throw InputError("parameter " + name + ": '" + text
                     + "' is not a finite number");
  set(name, *value);
}

bool ParameterSet::explicitly_set(const std::string& name) const
{
  return _explicit[index(name)];
}

std::vector<std::string> ParameterSet::names() const
{
  std::vector<std::string> out;
  for (const ParameterSpec& s : parameter_specs(_model))
    out.push_back(s.name);
  return out;
}

void ParameterSet::update_derived()
{
  if (uses_twitch_train(_model) and !_explicit[index("P_opt")])
    _values[index("P_opt")] = TwitchTrain(*this).tetanic_level();
}

void ParameterSet::validate() const
{
  const auto& specs = parameter_specs(_model);
  for (std::size_t i = 0; i < specs.size(); ++i)
  {
    const ParameterSpec& s = specs[i];
    const double v = _values[i];
    const bool low_ok = s.lower_open ? v > s.lower : v >= s.lower;
    const bool high_ok = s.upper_open ? v < s.upper : v <= s.upper;
    if (std::isfinite(v) and low_ok and high_ok)
      continue;
    std::string allowed;
    if (std::isfinite(s.lower) and std::isfinite(s.upper))
      allowed = (s.lower_open ? "(" : "[") + format_value(s.lower) + ", "
                + format_value(s.upper) + (s.upper_open ? ")" : "]");
    else if (std::isfinite(s.lower))
      allowed = (s.lower_open ? "> " : ">= ") + format_value(s.lower);
    else
      allowed = "a finite number";
    throw InputError("parameter " + s.name + " = " + format_value(v) + " ("
                     + s.meaning + ") of model " + to_string(_model)
                     + " is not admissible: must be " + allowed);
  }
  if (has("lambda_min") and (*this)["lambda_min"] >= (*this)["lambda_opt"])
  {
    throw InputError("parameters lambda_min = "
                     + format_value((*this)["lambda_min"]) + " and lambda_opt = "
                     + format_value((*this)["lambda_opt"]) + " of model "
                     + to_string(_model)
                     + " are not admissible: must have lambda_min < lambda_opt");
  }
}

std::string ParameterSet::to_text() const
{
  std::string out;
  const auto& specs = parameter_specs(_model);
  for (std::size_t i = 0; i < specs.size(); ++i)
    out += specs[i].name + "=" + format_value(_values[i]) + "\n";
  return out;
}

void read_parameter_file(const std::string& path, ParameterSet& p)
{
  std::ifstream in(path);
  if (!in)
    throw InputError("cannot read parameter file " + path);
  std::string line;
  int number = 0;
  while (std::getline(in, line))
  {
    ++number;
    const auto b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos or line[b] == '#')
      continue;
    const auto e = line.find_last_not_of(" \t\r");
    try
    {
      p.set_assignment(line.substr(b, e - b + 1));
    }
    catch (const InputError& err)
    {
      throw InputError(path + ":" + std::to_string(number) + ": " + err.what());
    }
  }
}

} // namespace muscle
