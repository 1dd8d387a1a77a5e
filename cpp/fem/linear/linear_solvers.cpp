#include "fem/linear/linear_solvers.h"

#include "common/errors.h"

namespace muscle
{

const std::vector<LinearSolverType>& linear_solver_table()
{
  static const std::vector<LinearSolverType> table = [] {
    const auto direct = [](const LinearSettings&, const DisplacementSpace&)
    { return std::unique_ptr<MatrixSolver>(std::make_unique<DirectSolver>()); };
    const auto amg = [](AmgSolver::Type type)
    {
      return [type](const LinearSettings& settings, const DisplacementSpace& space)
      { return std::unique_ptr<MatrixSolver>(std::make_unique<AmgSolver>(type, settings, space)); };
    };
    const auto penalty_split = [](const LinearSettings& settings, const DisplacementSpace& space,
                                  const std::vector<std::unique_ptr<FbarCellUnknowns>>& cells,
                                  Mat A, Vec layout)
    { return std::make_unique<PenaltySplit>(settings, space, cells, A, layout); };
    const auto split = [](bool stars)
    {
      return [stars](const LinearSettings& settings, const DisplacementSpace& space,
                     const DirichletBCs& bcs, const ParameterSet& parameters,
                     const std::string& kernels)
      {
        if (stars)
          TaylorHoodSplit::set_stars_defaults();
        return std::make_unique<TaylorHoodSplit>(settings, space, bcs, parameters, kernels,
                                                 stars ? TaylorHoodSplit::stars_al_gamma : 0);
      };
    };
    std::vector<LinearSolverType> t(5);
    t[0].name = "lu";
    t[0].summary = "MUMPS, the default";
    t[0].matrix = direct;
    t[0].on_assembled_blocks = true;
    t[1].name = "gmres-hypre";
    t[1].summary = "GMRES with BoomerAMG";
    t[1].matrix = amg(AmgSolver::Type::hypre);
    t[2].name = "gmres-gamg";
    t[2].summary = "GMRES with GAMG and the rigid-body modes";
    t[2].matrix = amg(AmgSolver::Type::gamg);
    t[3].name = "gmres-schur";
    t[3].summary = "F-bar: the penalty split; Taylor-Hood: the Schur field split";
    t[3].condensed = penalty_split;
    t[3].blocks = split(false);
    t[3].refused = "linear solver gmres-schur: only for F-bar elements with the three-field "
                   "Newton (element.fbar: true, cell unknowns on) and for Taylor-Hood elements "
                   "(element.taylor_hood: true)";
    t[4].name = "gmres-stars";
    t[4].summary = "Taylor-Hood: that split relaxed on vertex stars";
    t[4].blocks = split(true);
    t[4].refused = "linear solver gmres-stars: the Taylor-Hood field split relaxed on vertex "
                   "stars, for element.taylor_hood: true (--taylor-hood) only; this run's "
                   "element has no pressure unknowns (for F-bar: gmres-schur)";
    return t;
  }();
  return table;
}

const std::vector<std::string>& linear_solver_names()
{
  static const std::vector<std::string> names = []
  {
    std::vector<std::string> n;
    for (const LinearSolverType& t : linear_solver_table())
      n.push_back(t.name);
    return n;
  }();
  return names;
}

const LinearSolverType& linear_solver_type(const std::string& name)
{
  for (const LinearSolverType& t : linear_solver_table())
    if (t.name == name)
      return t;
  throw InputError("linear solver '" + name + "' is not allowed; allowed: "
                   + join(linear_solver_names()) + did_you_mean(name, linear_solver_names()));
}

void refuse_on_taylor_hood(const LinearSolverType& type)
{
  throw InputError("linear solver " + type.name
                   + ": the Taylor-Hood system (displacement and pressure) is solved by MUMPS "
                     "(linear: lu) or by GMRES with its Schur complement (linear: gmres-schur, "
                     "or gmres-stars relaxing it on vertex stars)");
}

void refuse_without_pressure(const LinearSolverType& type) { throw InputError(type.refused); }

} // namespace muscle
