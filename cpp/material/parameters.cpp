#include "parameters.h"

#include "../common/errors.h"
#include "time_functions.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace muscle
{
namespace
{
constexpr double inf = std::numeric_limits<double>::infinity();

ParameterSpec positive(std::string name, double preset, std::string unit,
                       std::string meaning)
{
  return {std::move(name), preset, 0, inf, true, true, std::move(unit),
          std::move(meaning)};
}

ParameterSpec nonnegative(std::string name, double preset, std::string unit,
                          std::string meaning)
{
  return {std::move(name), preset, 0, inf, false, true, std::move(unit),
          std::move(meaning)};
}

std::vector<ParameterSpec> time_parameters()
{
  return {positive("c", 34.4017, "1/s", "frequency of the tanh activation"),
          {"t0", 0.0, -inf, inf, true, true, "s", "activation start time"}};
}

std::vector<ParameterSpec> ble_specs()
{
  std::vector<ParameterSpec> s = {
      nonnegative("G1", 0.1, "kPa", "along-fibre shear modulus"),
      nonnegative("G2", 0.05, "kPa", "transverse-fibre shear modulus"),
      nonnegative("P1", 3.6055, "-", "magnitude of passive fibre tension"),
      positive("P2", 4.4883, "-", "exponential rate of passive fibre tension"),
      positive("lambda_opt", 1.2264, "-", "optimal fibre stretch"),
      {"lambda_star", 1.4, 1, inf, true, true, "-",
       "fibre stretch where passive tension turns linear"},
      nonnegative("sigma_max", 1.145, "kPa", "maximum isometric stress"),
      nonnegative("alpha_a", 69.5471, "-", "activation amplitude"),
  };
  for (auto& t : time_parameters())
    s.push_back(t);
  s.push_back(nonnegative("mu", 10.0, "kPa", "Neo-Hooke shear modulus"));
  s.push_back(positive("kappa", 10000.0, "kPa", "bulk modulus"));
  return s;
}

std::vector<ParameterSpec> ehret_specs(Model model)
{
  std::vector<ParameterSpec> s = {
      positive("alpha", 2.3796, "-", "along-fibre exponent"),
      positive("beta", 0.5161, "-", "transverse exponent"),
      positive("gamma", 27.1072, "kPa", "stiffness"),
      {"omega_0", 0.6388, 0, 1, false, false, "-",
       "weight of the isotropic matrix"},
      positive("kappa", 1000.0, "-", "incompressibility parameter"),
      positive("lambda_opt", 1.1806, "-", "optimal fibre stretch"),
      positive("lambda_min", 0.5680, "-", "minimal active fibre stretch"),
      nonnegative("P_opt", 64.6809, "kPa", "peak active nominal stress"),
  };
  for (auto& t : time_parameters())
    s.push_back(t);
  if (uses_twitch_train(model))
  {
    s.push_back(nonnegative("N_a", 0.4619, "1/mm^2",
                            "activated motor units per reference area"));
    const double F[] = {2.5, 4.4, 76.8};
    const double T[] = {0.02, 0.011, 0.011};
    const double rho[] = {0.05, 0.29, 0.66};
    for (int i = 0; i < 3; ++i)
    {
      const std::string k = std::to_string(i + 1);
      s.push_back(nonnegative("F_" + k, F[i], "mN", "twitch force of type " + k));
      s.push_back(positive("T_" + k, T[i], "s", "twitch contraction time"));
      s.push_back(positive("I_" + k, 0.004, "s", "interstimulus interval"));
      s.push_back({"rho_" + k, rho[i], 0, 1, false, false, "-",
                   "fraction of motor-unit type " + k});
    }
  }
  return s;
}

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

const std::vector<Model>& all_models()
{
  static const std::vector<Model> models
      = {Model::ble, Model::wkm, Model::giant, Model::combi};
  return models;
}

std::string to_string(Model model)
{
  switch (model)
  {
  case Model::ble:
    return "ble";
  case Model::wkm:
    return "wkm";
  case Model::giant:
    return "giant";
  case Model::combi:
    return "combi";
  }
  return "?";
}

Model parse_model(const std::string& name)
{
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  std::vector<std::string> names;
  for (Model m : all_models())
  {
    if (lower == to_string(m))
      return m;
    names.push_back(to_string(m));
  }
  throw InputError("unknown model '" + name + "'" + did_you_mean(lower, names)
                   + "; allowed: " + join(names));
}

bool uses_twitch_train(Model model)
{
  return model == Model::wkm or model == Model::giant;
}

const std::vector<ParameterSpec>& parameter_specs(Model model)
{
  static const std::vector<ParameterSpec> ble = ble_specs();
  static const std::vector<ParameterSpec> wkm = ehret_specs(Model::wkm);
  static const std::vector<ParameterSpec> giant = ehret_specs(Model::giant);
  static const std::vector<ParameterSpec> combi = ehret_specs(Model::combi);
  switch (model)
  {
  case Model::ble:
    return ble;
  case Model::wkm:
    return wkm;
  case Model::giant:
    return giant;
  default:
    return combi;
  }
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
