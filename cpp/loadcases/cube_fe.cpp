#include "loadcases/cube_fe.h"

#include "common/errors.h"
#include "fem/constraints/boundary.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/mesh/generation.h>
#include <dolfinx/mesh/utils.h>
#include <xtensor/xview.hpp>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// One Dirichlet condition of a load case: component `component` on the face
/// X_axis = side; `loaded` faces move with the control value.
struct FaceCondition
{
  int axis;
  double side;
  int component;
  bool loaded;
};

std::vector<FaceCondition> conditions(LoadCase c)
{
  switch (c)
  {
  case LoadCase::UTCAF:
    return {{2, 0, 2, false}, {2, 1, 2, true}, {0, 0, 0, false}, {1, 0, 1, false}};
  case LoadCase::UTCTF:
    return {{0, 0, 0, false}, {0, 1, 0, true}, {1, 0, 1, false}, {2, 0, 2, false}};
  case LoadCase::SAF:
    return {{1, 0, 1, false}, {1, 0, 2, false}, {1, 1, 1, false},
            {1, 1, 2, true},  {0, 0, 0, false}};
  case LoadCase::PSAF:
    return {{2, 0, 2, false}, {2, 1, 2, true}, {1, 0, 1, false},
            {1, 1, 1, false}, {0, 0, 0, false}};
  case LoadCase::PSTF:
    return {{0, 0, 0, false}, {0, 1, 0, true}, {1, 0, 1, false},
            {1, 1, 1, false}, {2, 0, 2, false}};
  case LoadCase::PSTIF:
    return {{0, 0, 0, false}, {0, 1, 0, true}, {2, 0, 2, false},
            {2, 1, 2, false}, {1, 0, 1, false}};
  }
  return {};
}

std::vector<std::int32_t> face_facets(const mesh::Mesh& mesh, int axis, double side)
{
  return mesh::locate_entities_boundary(
      mesh, 2,
      [axis, side](auto&& x) -> xt::xtensor<bool, 1>
      { return xt::isclose(xt::row(x, axis), side); });
}

} // namespace

CubeLoadCase::CubeLoadCase(const ParameterSet& parameters, MuscleState state,
                           LoadCase load_case, CubeOptions options)
    : _case(load_case), _options(std::move(options))
{
  if (_options.cells_per_side < 1)
    throw InputError("cells_per_side must be at least 1, got "
                     + std::to_string(_options.cells_per_side));
  const auto n = static_cast<std::size_t>(_options.cells_per_side);
  if (load_case == LoadCase::SAF and n != 1)
    throw InputError("SAF is defined on a single element (cells_per_side = 1)");
  auto mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1, 1}}}, {n, n, n},
      mesh::CellType::hexahedron, mesh::GhostMode::none));
  mesh->topology_mutable().create_connectivity(2, 3);
  _problem = std::make_shared<MuscleProblem>(mesh, parameters, _options.discretisation);
  _problem->set_fibre({0, 0, 1});
  _target_time_factor = state == MuscleState::active ? 1.0 : 0.0;

  std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs;
  auto V = _problem->V();
  for (const FaceCondition& f : conditions(load_case))
  {
    auto g = std::make_shared<fem::Constant<double>>(0.0);
    if (f.loaded)
      _loads.push_back(g);
    bcs.push_back(prescribe_component(V, face_facets(*mesh, f.axis, f.side), f.component, g));
  }
  const ReportedComponent out = reported_component(load_case);
  _loaded_dofs = component_dofs(*V, face_facets(*mesh, out.j, 1.0), out.i);
  _solver = std::make_unique<NonlinearSolver>(*_problem, bcs, nullptr, _options.newton);
  reset();
}

CubeLoadCase::~CubeLoadCase() = default;

void CubeLoadCase::reset()
{
  auto& u = *_problem->u()->x();
  std::fill(u.mutable_array().begin(), u.mutable_array().end(), 0.0);
  _current = _case == LoadCase::SAF ? 0.0 : 1.0;
  apply_control(_current);
  // Activated, a cube with a free fibre face is out of equilibrium in its
  // undeformed shape: ramp the activation up at the reference control first.
  _time_factor = 0;
  _problem->set_time_factor(0);
  CubeResult ramp;
  if (!continuation([this](double f) { _problem->set_time_factor(f); }, _time_factor,
                    _target_time_factor, 0.25, ramp))
  {
    throw SolveError("activation ramp of the cube failed: " + ramp.message);
  }
}

void CubeLoadCase::apply_control(double s)
{
  // face displacement: d (lambda - 1) for stretches, d nu for the shear (d = 1)
  const double value = _case == LoadCase::SAF ? s : s - 1;
  for (auto& g : _loads)
    g->value = {value};
}

double CubeLoadCase::reaction() const
{
  la::Vector<double> b(_problem->V()->dofmap()->index_map,
                       _problem->V()->dofmap()->index_map_bs());
  _solver->assemble_nodal_forces(b);
  return sum_owned(b, _loaded_dofs); // reference face area is 1
}

bool CubeLoadCase::continuation(const std::function<void(double)>& set,
                                double& current, double target, double max_step,
                                CubeResult& result)
{
  auto& u = *_problem->u()->x();
  std::vector<double> converged(u.array().begin(), u.array().end());
  double step = std::min(max_step, std::abs(target - current));
  int cutbacks = 0;
  while (current != target)
  {
    const double direction = target > current ? 1.0 : -1.0;
    double next = current + direction * step;
    if ((target - next) * direction < 1e-12)
      next = target;
    set(next);
    _last = _solver->solve();
    result.newton_iterations += _last.iterations;
    if (_last.converged)
    {
      current = next;
      std::copy(u.array().begin(), u.array().end(), converged.begin());
      continue;
    }
    // back to the last converged state, halve the increment
    std::copy(converged.begin(), converged.end(), u.mutable_array().begin());
    u.scatter_fwd();
    set(current);
    if (++cutbacks > _options.max_cutbacks)
    {
      result.message = "Newton failed (" + _last.reason + ") between "
                       + std::to_string(current) + " and " + std::to_string(next)
                       + " after " + std::to_string(_options.max_cutbacks)
                       + " cutbacks";
      return false;
    }
    step /= 2;
  }
  return true;
}

CubeResult CubeLoadCase::advance_to(double target)
{
  CubeResult result;
  result.control = target;
  if (!continuation([this](double s) { apply_control(s); }, _current, target,
                    _options.max_increment, result))
  {
    return result;
  }
  result.converged = true;
  result.stress = reaction();
  result.volume_ratio = _problem->volume();
  return result;
}

std::vector<CubeResult> CubeLoadCase::solve(const std::vector<double>& controls)
{
  const double reference = _case == LoadCase::SAF ? 0.0 : 1.0;
  std::vector<std::size_t> above, below;
  for (std::size_t i = 0; i < controls.size(); ++i)
    (controls[i] >= reference ? above : below).push_back(i);
  std::sort(above.begin(), above.end(),
            [&](auto a, auto b) { return controls[a] < controls[b]; });
  std::sort(below.begin(), below.end(),
            [&](auto a, auto b) { return controls[a] > controls[b]; });

  std::vector<CubeResult> results(controls.size());
  for (const auto* branch : {&above, &below})
  {
    reset();
    bool failed = false;
    for (std::size_t i : *branch)
    {
      if (failed)
      {
        results[i].control = controls[i];
        results[i].message = "not attempted: an earlier point on this branch failed";
        continue;
      }
      results[i] = advance_to(controls[i]);
      failed = !results[i].converged;
    }
  }
  return results;
}

} // namespace muscle
