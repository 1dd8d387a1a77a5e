#pragma once

#include "forms/form_registry.h"

#include <string>
#include <vector>

namespace muscle
{

/// A material law of the registry: forms/materials/*.py and the files named in
/// MUSCLE_MATERIALS, one law a file (docs/materials.md).  What C++ knows of a law
/// comes from the declarations in its file (forms::LawInfo).
class Model
{
public:
  /// The law of this name (case-insensitive); InputError listing the laws otherwise.
  explicit Model(const std::string& name);

  std::string name() const { return _law->name; }
  const forms::LawInfo& law() const { return *_law; }
  /// Has an active term (drive other than "none").
  bool active() const;
  /// omega_a comes from a C++ quadrature-point kernel (WKM, GIANT).
  bool has_activation_kernel() const;

  bool operator==(const Model& other) const { return _law == other._law; }

private:
  const forms::LawInfo* _law;
};

/// Every law of the registry, in file-name order.
const std::vector<Model>& all_models();

/// The law whose file declares itself the default for `role` (DEFAULT_FOR; one law
/// per role, checked at the configure step): "muscle" (a scene part without a
/// material, fusiform), "fit" (a fit result before the fit).
Model default_model(const std::string& role);

/// Every law whose file declares `role` (DEFAULT_FOR), in file-name order: "paper",
/// the paper's models.
std::vector<Model> models_for(const std::string& role);
std::string to_string(const Model& model);
Model parse_model(const std::string& name);

/// The law's activation follows a motor-unit twitch train (WKM, GIANT) rather
/// than tanh(c (t - t0)) (BLE, COMBI).
bool uses_twitch_train(const Model& model);

/// One material parameter: its preset value (the law file's; for the paper's
/// laws Table fitting_all) and the admissible range.
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

const std::vector<ParameterSpec>& parameter_specs(const Model& model);

/// Material parameters of one law: preset values, overridable by name.
///
/// Units: mm, s, kPa.  For twitch-train laws (WKM, GIANT), P_opt (the peak active nominal stress
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
