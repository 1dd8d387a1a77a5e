#pragma once

#include <initializer_list>
#include <petscsys.h>
#include <string>
#include <utility>

namespace muscle
{

/// A solver's own PETSc options database: a copy of the process's (the command
/// line's and a scene's options) when made, to which the solver adds its
/// defaults (set_unless_given while it is active).  While an `Active` scope
/// lives it is PETSc's default database, so every object the solver sets up or
/// solves with -- the nested ones PETSc creates itself (field split blocks,
/// multigrid levels) included -- reads it, and nothing the solver sets reaches
/// the process's database or another solver.  Scopes nest (a stack).
class SolverOptions
{
public:
  SolverOptions();
  ~SolverOptions();
  SolverOptions(const SolverOptions&) = delete;
  SolverOptions& operator=(const SolverOptions&) = delete;

  class Active
  {
  public:
    explicit Active(const SolverOptions& options);
    ~Active();
    Active(const Active&) = delete;
    Active& operator=(const Active&) = delete;
  };
  /// This database as the default one for the scope of the returned object.
  [[nodiscard]] Active activate() const { return Active(*this); }

private:
  PetscOptions _options = nullptr;
};

/// Sets PETSc option `name` (to `value`, or as a flag if null) unless the user
/// gave it: the command line wins over a scene's or a solver's defaults.
void set_unless_given(const char* name, const char* value);

/// The same for each (name, value) pair.
void set_unless_given(std::initializer_list<std::pair<const char*, const char*>> options);

/// The string option `name`, or "" if not given.
std::string string_option(const char* name);

/// Reads the string option `name` into `value` if given; it must be one of
/// `allowed`, or InputError names what is.
void choice_option(const char* name, std::initializer_list<const char*> allowed,
                   std::string& value);

/// Whether any -`prefix`pc_factor_* option is given (e.g. prefix "fieldsplit_q_"): the
/// user chose a factorisation there.
bool factor_options_given(const std::string& prefix);

/// An inner Krylov method (option `inner`: a -*_ksp_type other than preonly,
/// richardson or chebyshev) makes preconditioner `what` vary between applications;
/// right-preconditioned GMRES assumes it fixed and would report a residual its
/// solution does not have.  InputError unless -ksp_type is flexible (fgmres, gcr,
/// pipefgmres, fbcgs, fbcgsr).
void require_flexible_outer(const char* inner, const std::string& what);

/// require_flexible_outer for every -`prefix`*ksp_type given, e.g. prefix "fieldsplit_":
/// each solver nested in the preconditioner (a block, a multigrid level, level 3 of
/// it alone) makes it vary when it is a Krylov method.
void require_flexible_outer_under(const std::string& prefix, const std::string& what);

} // namespace muscle
