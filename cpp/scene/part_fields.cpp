#include "scene/part_fields.h"

#include "common/application.h"
#include "common/errors.h"
#include "fem/elements/fibres.h"
#include "fem/elements/muscle_problem.h"
#include "io/gmsh_mesh.h"
#include "scene/point_data.h"
#include "scene/scene_model.h"

#include <cmath>
#include <dolfinx/mesh/utils.h>
#include <map>

using namespace dolfinx;

namespace muscle
{

ScaleField::ScaleField(const ActivationScale& spec, const GmshMesh& gm,
                       fem::Function<double>& scale, const std::vector<std::int32_t>& cells)
    : _spec(spec), _scale(scale)
{
  const auto& mesh = *gm.mesh;
  _midpoints = mesh::compute_midpoints(mesh, 3, cells);
  _dofs.resize(cells.size());
  for (std::size_t c = 0; c < cells.size(); ++c)
    _dofs[c] = scale.function_space()->dofmap()->cell_dofs(cells[c])[0];
  if (spec.kind == ActivationScale::Kind::groups)
  {
    std::map<int, double> by_tag;
    for (const auto& [name, value] : spec.groups)
    {
      auto it = gm.volumes.find(name);
      if (it == gm.volumes.end())
      {
        std::vector<std::string> names;
        for (const auto& [n, _] : gm.volumes)
          names.push_back(n);
        throw InputError(spec.where.text() + ": the mesh has no volume group '" + name
                         + "'; it has: " + join(names) + did_you_mean(name, names));
      }
      by_tag[it->second] = value;
    }
    // cell -> physical volume tag (the Gmsh reader tags every local cell)
    std::map<std::int32_t, int> tag_of;
    for (std::size_t i = 0; i < gm.cell_tags->indices().size(); ++i)
      tag_of[gm.cell_tags->indices()[i]] = gm.cell_tags->values()[i];
    _fixed.assign(cells.size(), spec.other);
    for (std::size_t c = 0; c < cells.size(); ++c)
      if (auto it = by_tag.find(tag_of[cells[c]]); it != by_tag.end())
        _fixed[c] = it->second;
  }
  else if (spec.kind == ActivationScale::Kind::file)
  {
    _data = std::make_unique<PointData>(spec.path, 0);
    if (!_data->timed() and _data->columns() != 1)
      throw InputError(spec.path + ": expected one value column (x,y,z,scale) or time "
                                   "columns (x,y,z,0,0.05,...)");
    for (std::size_t c = 0; c < cells.size(); ++c)
      _rows.push_back(_data->nearest({_midpoints[3 * c], _midpoints[3 * c + 1],
                                      _midpoints[3 * c + 2]}));
  }
  update(0.0, true);
}

ScaleField::~ScaleField() = default;

double ScaleField::largest() const
{
  double local = 0, global = 0;
  for (std::int32_t dof : _dofs)
    local = std::max(local, _scale.x()->array()[dof]);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, _scale.function_space()->mesh()->comm());
  return global;
}

bool ScaleField::time_dependent() const
{
  return (_spec.kind == ActivationScale::Kind::expression and _spec.formula->uses("t"))
         or (_data and _data->timed());
}

void ScaleField::update(double t, bool first)
{
  if (!first and !time_dependent())
    return;
  std::span<double> x = _scale.x()->mutable_array();
  std::string error;
  for (std::size_t c = 0; c < _dofs.size() and error.empty(); ++c)
  {
    double v = _spec.value;
    switch (_spec.kind)
    {
    case ActivationScale::Kind::groups:
      v = _fixed[c];
      break;
    case ActivationScale::Kind::expression:
    {
      const double args[4] = {_midpoints[3 * c], _midpoints[3 * c + 1], _midpoints[3 * c + 2], t};
      v = (*_spec.formula)(args);
      break;
    }
    case ActivationScale::Kind::file:
      v = _data->value_at(_rows[c], t);
      break;
    default:
      break;
    }
    if (!std::isfinite(v) or v < 0)
      error = _spec.where.text() + ": the activation scale is " + std::to_string(v)
              + " in the cell at (" + std::to_string(_midpoints[3 * c]) + ", "
              + std::to_string(_midpoints[3 * c + 1]) + ", "
              + std::to_string(_midpoints[3 * c + 2]) + ") at t = " + std::to_string(t)
              + "; it must be finite and >= 0";
    x[_dofs[c]] = v;
  }
  // a bad value in one rank's cells stops every rank
  throw_if_any(_scale.function_space()->mesh()->comm(), error);
}

void set_fibres(const FibreSpec& spec, const SceneModel& model, MuscleProblem& problem)
{
  const GmshMesh& gm = model.gm;
  if (spec.kind == FibreSpec::Kind::direction)
    problem.set_fibre(spec.direction);
  else if (spec.kind == FibreSpec::Kind::laplace)
  {
    try
    {
      // the potential and the fibres on the part's cells
      const LaplaceFibres fibres = laplace_fibres(
          gm.mesh, *gm.facet_tags, model.surface(spec.from, spec.where),
          model.surface(spec.to, spec.where), problem.fibre()->function_space(),
          &problem.cells());
      problem.set_fibre(*fibres.fibre);
    }
    catch (const InputError& e)
    {
      if (std::string(e.what()).rfind(spec.where.file, 0) == 0)
        throw;
      throw InputError(spec.where.text() + ": " + e.what());
    }
  }
  else
  {
    const PointData data(spec.path, 3);
    const std::vector<std::int32_t>& cells = problem.cells();
    const std::vector<double> mid = mesh::compute_midpoints(*gm.mesh, 3, cells);
    auto& fibre = *problem.fibre();
    std::span<double> x = fibre.x()->mutable_array();
    std::string error;
    for (std::size_t c = 0; c < cells.size() and error.empty(); ++c)
    {
      const std::size_t row = data.nearest({mid[3 * c], mid[3 * c + 1], mid[3 * c + 2]});
      const double a[3] = {data.value(row, 0), data.value(row, 1), data.value(row, 2)};
      const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      if (!(n > 0))
        error = spec.where.text() + ": " + spec.path + ":" + std::to_string(data.line(row))
                + ": zero fibre direction (nearest point of a cell)";
      const std::int32_t dof = fibre.function_space()->dofmap()->cell_dofs(cells[c])[0];
      for (int k = 0; k < 3 and error.empty(); ++k)
        x[3 * dof + k] = a[k] / n;
    }
    throw_if_any(gm.mesh->comm(), error);
  }
}

} // namespace muscle
