#include "common/petsc_options.h"
#include "common/errors.h"
#include <petscsys.h>

#include <algorithm>
#include <cctype>
#include <sstream>
#include <vector>

namespace muscle
{

SolverOptions::SolverOptions()
{
  PetscOptionsCreate(&_options);
  char* all = nullptr;
  PetscOptionsGetAll(nullptr, &all);
  if (all)
    PetscOptionsInsertString(_options, all);
  PetscFree(all);
}

SolverOptions::~SolverOptions() { PetscOptionsDestroy(&_options); }

SolverOptions::Active::Active(const SolverOptions& options) { PetscOptionsPush(options._options); }

SolverOptions::Active::~Active() { PetscOptionsPop(); }

void set_unless_given(const char* name, const char* value)
{
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, name, &given);
  if (!given)
    PetscOptionsSetValue(nullptr, name, value);
}

void set_unless_given(std::initializer_list<std::pair<const char*, const char*>> options)
{
  for (const auto& [name, value] : options)
    set_unless_given(name, value);
}

std::string string_option(const char* name)
{
  char value[256] = "";
  PetscOptionsGetString(nullptr, nullptr, name, value, sizeof(value), nullptr);
  return value;
}

void choice_option(const char* name, std::initializer_list<const char*> allowed,
                   std::string& value)
{
  PetscBool given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, name, &given);
  if (!given)
    return;
  const std::string given_value = string_option(name);
  std::string list;
  for (const char* a : allowed)
  {
    if (given_value == a)
    {
      value = a;
      return;
    }
    list += std::string(list.empty() ? "" : ", ") + a;
  }
  throw InputError(std::string(name) + " " + given_value + ": allowed are " + list);
}

void require_flexible_outer(const char* inner, const std::string& what)
{
  const std::string type = string_option(inner);
  const std::string outer = string_option("-ksp_type");
  // PETSc's Krylov methods that take a preconditioner varying between applications,
  // on the right as configure_linear_solver sets it (fcg, pipefcg and pipegcr take
  // it on the left only, and CG assumes a symmetric positive definite system)
  const std::vector<std::string> flexible = {"fgmres", "gcr", "pipefgmres", "fbcgs", "fbcgsr"};
  if (type.empty() or type == "preonly" or type == "richardson" or type == "chebyshev"
      or std::find(flexible.begin(), flexible.end(), outer) != flexible.end())
    return;
  throw InputError(std::string(inner) + " " + type + ": an inner Krylov method makes the "
                   + what + " vary between applications; the outer one must be flexible: "
                   "add -ksp_type fgmres (or gcr); this run has -ksp_type "
                   + (outer.empty() ? "gmres (the default)" : outer));
}

namespace
{
/// The words of the whole options database ("-name value ..."): PETSc has no query by
/// pattern
std::istringstream all_options()
{
  char* all = nullptr;
  PetscOptionsGetAll(nullptr, &all);
  std::istringstream words(all ? all : "");
  PetscFree(all);
  return words;
}
} // namespace

bool factor_options_given(const std::string& prefix)
{
  std::istringstream words = all_options();
  const std::string start = "-" + prefix + "pc_factor_";
  for (std::string word; words >> word;)
  {
    std::transform(word.begin(), word.end(), word.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (word.compare(0, start.size(), start) == 0)
      return true;
  }
  return false;
}

void require_flexible_outer_under(const std::string& prefix, const std::string& what)
{
  std::istringstream words = all_options();
  const std::string start = "-" + prefix, end = "ksp_type";
  for (std::string word; words >> word;)
  {
    // PETSc's option names ignore case
    std::transform(word.begin(), word.end(), word.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    // (Chebyshev's and GAMG's eigenvalue estimates, -*esteig_ksp_type, run once at
    // set-up: they do not make the preconditioner vary)
    if (word.size() >= start.size() + end.size() and word.compare(0, start.size(), start) == 0
        and word.compare(word.size() - end.size(), end.size(), end) == 0
        and word.find("esteig_") == std::string::npos)
      require_flexible_outer(word.c_str(), what);
  }
}

} // namespace muscle
