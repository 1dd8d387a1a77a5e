#include "scene/series_quantities.h"

#include "common/errors.h"
#include "fem/constraints/boundary.h"
#include "fem/time/generalized_alpha.h"
#include "fem/analysis/point_probe.h"
#include "fem/analysis/rigid_rotation.h"
#include "scene/scene_model.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/mesh/utils.h>
#include <limits>

using namespace dolfinx;

namespace muscle
{

SeriesQuantities::SeriesQuantities(const Scene& scene, const SceneModel& model)
    : _scene(scene), _model(model),
      _nodal(model.problem().V()->dofmap()->index_map, model.problem().V()->dofmap()->index_map_bs())
{
  auto V = model.problem().V();
  const auto& mesh = *model.gm.mesh;
  const double volume0 = model.volume();
  const MuscleProblem* first_active = nullptr;
  for (std::size_t p = 0; p < model.body.size() and !first_active; ++p)
    if (scene.parts[p].active)
      first_active = model.body[p];
  for (const SeriesQuantity& q : scene.output.series)
  {
    using K = SeriesQuantity::Kind;
    std::vector<std::int32_t> dofs;
    if (!q.surface.empty())
      dofs = component_dofs(*V, model.facets(q.surface, q.where), q.component);
    std::int64_t count = dofs.size(), total = 0;
    const std::int32_t owned = V->dofmap()->index_map->size_local() * 3;
    count = std::count_if(dofs.begin(), dofs.end(), [&](auto d) { return d < owned; });
    MPI_Allreduce(&count, &total, 1, MPI_INT64_T, MPI_SUM, mesh.comm());
    switch (q.kind)
    {
    case K::activation:
      _measure.push_back([first_active]
                         { return first_active ? first_active->time_factor() : 0.0; });
      break;
    case K::reaction:
      _measure.push_back(reaction(q, dofs));
      break;
    case K::section_force:
      _measure.push_back(section_force(q, dofs));
      break;
    case K::displacement:
    case K::stretch_ratio:
    {
      const double length = q.kind == K::stretch_ratio ? q.length : 0;
      auto u = model.problem().u();
      _measure.push_back(
          [u, dofs, total, length]
          {
            const double mean = sum_owned(*u->x(), dofs) / std::max<std::int64_t>(total, 1);
            return length > 0 ? 1 + mean / length : mean;
          });
      break;
    }
    case K::volume_change:
      _measure.push_back([&model, volume0] { return model.volume() / volume0 - 1; });
      break;
    case K::min_J:
      _measure.push_back(
          [&model]
          {
            double local = std::numeric_limits<double>::infinity();
            for (const MuscleProblem* part : model.body)
              local = std::min(local, part->min_jacobian_determinant().first);
            double global = 0;
            MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, model.gm.mesh->comm());
            return global;
          });
      break;
    case K::rotation:
      _measure.push_back(rotation(q));
      break;
    case K::contact_force:
    case K::contact_area:
    case K::max_pressure:
    case K::max_penetration:
      _measure.push_back(contact(q));
      break;
    case K::point:
      _measure.push_back(point(q));
      break;
    case K::kinetic_energy:
      if (!model.dynamics)
        throw InputError(q.where.text() + ": kinetic_energy needs a dynamic scene ('dynamics: "
                         "{method: generalized_alpha}' and every part's density)");
      _measure.push_back([&model] { return model.dynamics->kinetic_energy(); });
      break;
    case K::strain_energy:
      for (const MuscleProblem* part : model.body)
        if (part->reduced_volumetric())
          // its forces come from two rules, its energy functional has one
          throw InputError(q.where.text() + ": strain_energy is not available on the "
                           "anti-locking element (volumetric_quadrature_degree); use F-bar, "
                           "plain or quadratic elements");
      _measure.push_back(
          [&model]
          {
            double energy = 0;
            for (const MuscleProblem* part : model.body)
              energy += part->strain_energy();
            return energy;
          });
      break;
    }
  }
}

std::vector<double> SeriesQuantities::measure(const NonlinearSolver& solver)
{
  if (_need_nodal_forces)
    solver.assemble_nodal_forces(_nodal);
  std::vector<double> values(_measure.size());
  for (std::size_t k = 0; k < _measure.size(); ++k)
    values[k] = _measure[k]();
  return values;
}

SeriesQuantities::Measure SeriesQuantities::reaction(const SeriesQuantity& q,
                                                     const std::vector<std::int32_t>& dofs)
{
  if (!_model.supports.count(q.surface))
    throw InputError(q.where.text() + ": '" + q.surface
                     + "' carries no boundary condition, so there is no reaction; use "
                       "section_force for an interior surface");
  _need_nodal_forces = true;
  return [&nodal = _nodal, dofs] { return -sum_owned(nodal, dofs); };
}

SeriesQuantities::Measure
SeriesQuantities::section_force(const SeriesQuantity& q, const std::vector<std::int32_t>& dofs)
{
  // the residual of the cells on one side of the surface, summed over its
  // nodes; the side is decided along the surface's normal axis, so the
  // surface must be a plane x, y or z = const
  const auto mesh = _model.gm.mesh;
  const auto facets = _model.facets(q.surface, q.where);
  const std::vector<double> fm = mesh::compute_midpoints(*mesh, 2, facets);
  double low[3], high[3], lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t f = 0; f < facets.size(); ++f)
    for (int d = 0; d < 3; ++d)
    {
      lo[d] = std::min(lo[d], fm[3 * f + d]);
      hi[d] = std::max(hi[d], fm[3 * f + d]);
    }
  MPI_Allreduce(lo, low, 3, MPI_DOUBLE, MPI_MIN, mesh->comm());
  MPI_Allreduce(hi, high, 3, MPI_DOUBLE, MPI_MAX, mesh->comm());
  int normal = 0;
  for (int d = 1; d < 3; ++d)
    if (high[d] - low[d] < high[normal] - low[normal])
      normal = d;
  const double extent = std::max({high[0] - low[0], high[1] - low[1], high[2] - low[2]});
  if (!(high[normal] - low[normal] <= 1e-9 * extent))
    throw InputError(q.where.text() + ": section_force needs a plane surface x, y or z = "
                     "const; '" + q.surface + "' is not one (use reaction on a supported "
                     "surface)");
  const double level = 0.5 * (low[normal] + high[normal]);
  const std::vector<std::int32_t> cells = all_cells(*mesh);
  const std::vector<double> cm = mesh::compute_midpoints(*mesh, 3, cells);
  // each part contributes the residual of its own cells on that side
  std::vector<std::shared_ptr<fem::Form<double>>> forms;
  for (std::size_t p = 0; p < _model.body.size(); ++p)
  {
    std::vector<std::int32_t> side(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c)
      side[c] = (cm[3 * c + normal] < level) == (q.sign > 0)
                        and (!_model.part_tags or _model.part_tags->values()[c] == int(p) + 1)
                    ? 1
                    : 2;
    auto tags = std::make_shared<mesh::MeshTags<std::int32_t>>(mesh, 3, cells, side);
    forms.push_back(_model.body[p]->residual_on_cells(tags, 1));
    _keep_tags.push_back(tags);
  }
  const double sign = q.sign;
  return [&nodal = _nodal, forms, dofs, sign]
  {
    la::Vector<double> b(nodal.map(), nodal.bs());
    for (const auto& form : forms)
      fem::assemble_vector<double>(b.mutable_array(), *form);
    b.scatter_rev(std::plus<double>());
    return sign * sum_owned(b, dofs);
  };
}

SeriesQuantities::Measure SeriesQuantities::rotation(const SeriesQuantity& q) const
{
  std::size_t p = 0;
  while (p < _scene.parts.size() and _scene.parts[p].name != q.part)
    ++p;
  if (p == _scene.parts.size())
  {
    std::vector<std::string> names;
    for (const Part& part : _scene.parts)
      names.push_back(part.name);
    throw InputError(q.where.text() + ".part: no part named '" + q.part + "'; parts: "
                     + join(names));
  }
  const MuscleProblem* part = _model.body[p];
  const int c = q.component;
  return [&problem = _model.problem(), part, c]
  { return rotation_vector(*problem.u(), part->cells())[c]; };
}

SeriesQuantities::Measure SeriesQuantities::contact(const SeriesQuantity& q) const
{
  using K = SeriesQuantity::Kind;
  if (q.pair >= static_cast<int>(_model.contacts.size()))
    throw InputError(q.where.text() + ".pair: " + std::to_string(q.pair)
                     + " names no contact pair; the scene has "
                     + std::to_string(_model.contacts.size()));
  auto pair = _model.contacts[q.pair];
  const K kind = q.kind;
  return [pair, kind]
  {
    const ContactPair::Measures m = pair->measure();
    switch (kind)
    {
    case K::contact_force:
      return std::sqrt(m.force[0] * m.force[0] + m.force[1] * m.force[1]
                       + m.force[2] * m.force[2]);
    case K::contact_area:
      return m.area;
    case K::max_pressure:
      return m.max_pressure;
    default:
      return m.max_penetration;
    }
  };
}

SeriesQuantities::Measure SeriesQuantities::point(const SeriesQuantity& q) const
{
  auto probe = std::make_shared<PointProbe>(_model.problem().u(), q.at);
  const double size = _model.element_size();
  if (probe->distance() > 0.5 * size)
    throw InputError(q.where.text() + ".at: (" + std::to_string(q.at[0]) + ", "
                     + std::to_string(q.at[1]) + ", " + std::to_string(q.at[2])
                     + ") lies " + std::to_string(probe->distance())
                     + " mm outside the body, more than half an element; the nearest "
                       "material point is ("
                     + std::to_string(probe->point()[0]) + ", "
                     + std::to_string(probe->point()[1]) + ", "
                     + std::to_string(probe->point()[2]) + ")");
  const int c = q.component;
  const double offset = q.position ? probe->point()[c] : 0.0;
  return [probe, c, offset] { return offset + probe->displacement()[c]; };
}

} // namespace muscle
