#pragma once

#include <string>
#include <vector>

namespace muscle
{

/// The four muscle models of the paper.
enum class Model
{
  ble,   ///< Blemker active stress + Neo-Hooke
  wkm,   ///< Weickenmeier generalized active strain
  giant, ///< Giantesio active strain, implicit activation
  combi, ///< the paper's modified model
};

const std::vector<Model>& all_models();
std::string to_string(Model model);
/// Parse "ble", "wkm", "giant", "combi" (case-insensitive); InputError otherwise.
Model parse_model(const std::string& name);

/// WKM and GIANT drive activation by a motor-unit twitch train; BLE and COMBI by
/// tanh(c (t - t0)).
bool uses_twitch_train(Model model);

/// One material parameter: its preset value (paper Table fitting_all) and the
/// admissible range.
struct ParameterSpec
{
  std::string name;
  double preset;
  double lower;
  double upper;
  bool lower_open;  ///< lower bound excluded
  bool upper_open;  ///< upper bound excluded
  std::string unit; ///< mm, s, kPa (= mN/mm^2); "-" if dimensionless
  std::string meaning;
};

const std::vector<ParameterSpec>& parameter_specs(Model model);

/// Material parameters of one model: preset values, overridable by name.
///
/// Units: mm, s, kPa.  For WKM and GIANT, P_opt (the peak active nominal stress
/// used when the time factor is 1, e.g. in the active load cases) defaults to the
/// tetanic level of the twitch train, N_a sum_i rho_i G_i e F_i T_i / I_i, and
/// follows the twitch parameters unless it is set explicitly.
class ParameterSet
{
public:
  explicit ParameterSet(Model model);

  Model model() const { return _model; }

  /// Value by name; InputError naming the model's parameters if unknown.
  double operator[](const std::string& name) const;
  bool has(const std::string& name) const;

  /// Override a value (not yet checked for admissibility, see validate()).
  void set(const std::string& name, double value);

  /// Parse and apply "NAME=VALUE".
  void set_assignment(const std::string& assignment);

  bool explicitly_set(const std::string& name) const;

  /// Names in table order.
  std::vector<std::string> names() const;

  /// Throws InputError for the first inadmissible value: which parameter, which
  /// value, what is allowed.
  void validate() const;

  /// "name=value" lines for output files (readable by set_assignment).
  std::string to_text() const;

private:
  std::size_t index(const std::string& name) const;
  void update_derived();

  Model _model;
  std::vector<double> _values;
  std::vector<bool> _explicit;
};

/// Read a parameter file of "name=value" lines (as written by
/// ParameterSet::to_text(); blank lines, '#' comments and CRLF line ends
/// allowed) into `p`; InputError naming file and line.  Does not validate().
void read_parameter_file(const std::string& path, ParameterSet& p);

} // namespace muscle
