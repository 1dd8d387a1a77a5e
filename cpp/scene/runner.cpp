#include "runner.h"

#include "../common/application.h"
#include "../common/errors.h"
#include "../fem/boundary.h"
#include "../fem/contact.h"
#include "../fem/element_choice.h"
#include "../fem/fibres.h"
#include "../fem/loads.h"
#include "../fem/muscle_problem.h"
#include "../fem/point_probe.h"
#include "../fem/rigid_rotation.h"
#include "../fem/tie_constraint.h"
#include "../fem/uniform_constraint.h"
#include "../io/gmsh_mesh.h"
#include "../io/surface_export.h"
#include "../material/material_point.h"
#include "../material/time_functions.h"
#include "checkpoint.h"
#include "point_data.h"

#include <chrono>
#include <cstdio>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/io/XDMFFile.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/utils.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numeric>
#include <set>

using namespace dolfinx;

namespace muscle
{
namespace
{
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::size_t fingerprint(const std::string& text) { return std::hash<std::string>{}(text); }

std::vector<std::int32_t> all_cells(const mesh::Mesh& mesh)
{
  auto map = mesh.topology().index_map(3);
  std::vector<std::int32_t> cells(map->size_local() + map->num_ghosts());
  std::iota(cells.begin(), cells.end(), 0);
  return cells;
}

/// Cell-wise activation scale: evaluated once, or every step if it depends on t.
class ScaleField
{
public:
  /// `cells`: the local cells of the part the scale belongs to.
  ScaleField(const ActivationScale& spec, const GmshMesh& gm, fem::Function<double>& scale,
             const std::vector<std::int32_t>& cells)
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

  /// The largest value over every rank's cells (collective).
  double largest() const
  {
    double local = 0, global = 0;
    for (std::int32_t dof : _dofs)
      local = std::max(local, _scale.x()->array()[dof]);
    MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, _scale.function_space()->mesh()->comm());
    return global;
  }

  bool time_dependent() const
  {
    return (_spec.kind == ActivationScale::Kind::expression and _spec.formula->uses("t"))
           or (_data and _data->timed());
  }

  void update(double t, bool first = false)
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

private:
  const ActivationScale& _spec;
  fem::Function<double>& _scale;
  std::vector<double> _midpoints, _fixed;
  std::vector<std::int32_t> _dofs;
  std::unique_ptr<PointData> _data;
  std::vector<std::size_t> _rows;
};

void set_fibres(const FibreSpec& spec, const GmshMesh& gm, MuscleProblem& problem,
                const std::function<int(const std::string&, const SceneLocation&)>& surface)
{
  if (spec.kind == FibreSpec::Kind::direction)
    problem.set_fibre(spec.direction);
  else if (spec.kind == FibreSpec::Kind::laplace)
  {
    try
    {
      // the potential over the whole mesh, fibres on the part's cells
      const LaplaceFibres fibres = laplace_fibres(
          gm.mesh, *gm.facet_tags, surface(spec.from, spec.where), surface(spec.to, spec.where),
          problem.fibre()->function_space(), &problem.cells());
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

/// Time `count` residual and Jacobian assemblies of a problem's forms.
nlohmann::json time_assembly(MuscleProblem& problem, int count)
{
  Mat A = fem::petsc::create_matrix(*problem.jacobian(), "aij");
  la::Vector<double> b(problem.V()->dofmap()->index_map, problem.V()->dofmap()->index_map_bs());
  auto median = [](std::vector<double> v)
  {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::vector<double> residual, jacobian, kernel;
  for (int k = 0; k < count; ++k)
  {
    auto t0 = Clock::now();
    problem.update_activation();
    kernel.push_back(seconds_since(t0));
    t0 = Clock::now();
    std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
    fem::assemble_vector<double>(b.mutable_array(), *problem.residual());
    residual.push_back(seconds_since(t0));
    t0 = Clock::now();
    MatZeroEntries(A);
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *problem.jacobian(),
                         {});
    MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
    jacobian.push_back(seconds_since(t0));
  }
  MatDestroy(&A);
  return {{"forms", problem.kernel_name()},
          {"activation_kernel_s", problem.has_activation_kernel() ? median(kernel) : 0.0},
          {"residual_s", median(residual)},
          {"jacobian_s", median(jacobian)}};
}
/// Cells tagged with their part (index + 1) from the parts' volume groups;
/// null for a single part over the whole mesh.
std::shared_ptr<mesh::MeshTags<std::int32_t>> assign_parts(const Scene& scene,
                                                           const GmshMesh& gm)
{
  if (scene.parts.size() == 1 and scene.parts[0].volumes.empty())
    return nullptr;
  std::vector<std::string> names;
  for (const auto& [n, _] : gm.volumes)
    names.push_back(n);
  std::map<int, int> part_of_tag;
  std::map<int, std::string> owner;
  for (std::size_t p = 0; p < scene.parts.size(); ++p)
    for (const std::string& v : scene.parts[p].volumes)
    {
      auto it = gm.volumes.find(v);
      if (it == gm.volumes.end())
        throw InputError(scene.parts[p].where.text() + ".volumes: the mesh has no volume group '"
                         + v + "'; it has: " + join(names) + did_you_mean(v, names));
      if (part_of_tag.count(it->second))
        throw InputError(scene.parts[p].where.text() + ".volumes: '" + v
                         + "' already belongs to part '" + owner[it->second] + "'");
      part_of_tag[it->second] = static_cast<int>(p) + 1;
      owner[it->second] = scene.parts[p].name;
    }
  const std::vector<std::int32_t> cells = all_cells(*gm.mesh);
  std::vector<std::int32_t> values(cells.size(), 0);
  for (std::size_t i = 0; i < gm.cell_tags->indices().size(); ++i)
    if (auto it = part_of_tag.find(gm.cell_tags->values()[i]); it != part_of_tag.end())
      values[gm.cell_tags->indices()[i]] = it->second;
  const std::int32_t owned = gm.mesh->topology().index_map(3)->size_local();
  std::int64_t orphans = std::count(values.begin(), values.begin() + owned, 0), total = 0;
  MPI_Allreduce(&orphans, &total, 1, MPI_INT64_T, MPI_SUM, gm.mesh->comm());
  if (total > 0)
  {
    std::vector<std::string> free;
    for (const auto& [n, t] : gm.volumes)
      if (!part_of_tag.count(t))
        free.push_back(n);
    throw InputError(scene.file + ": parts: " + std::to_string(total)
                     + " cells belong to no part (volume groups in no part: "
                     + (free.empty() ? "none; cells without a volume group" : join(free)) + ")");
  }
  return std::make_shared<mesh::MeshTags<std::int32_t>>(gm.mesh, 3, cells, values);
}
} // namespace

void run_scene(const Scene& scene, const RunOptions& options)
{
  const auto start = Clock::now();
  std::filesystem::create_directories(options.out);

  // Mesh with its named surfaces and volumes
  const GmshMesh gm = [&]
  {
    try
    {
      return read_gmsh(MPI_COMM_WORLD, scene.mesh.path, scene.mesh.numbers);
    }
    catch (const InputError& e)
    {
      // located at the scene's mesh key: the numbers that made it come from there
      throw InputError((scene.mesh.numbers.empty() ? scene.mesh.where
                                                    : scene.mesh.numbers_where).text()
                       + ": " + e.what());
    }
  }();
  auto mesh = gm.mesh;

  // The element: F-bar on degree-1 hexahedra unless the scene says otherwise;
  // plain linear elements under a nearly incompressible law get a warning
  const std::string cell_type = mesh::to_string(mesh->topology().cell_type());
  const bool anti_locking = scene.mesh.volumetric_quadrature_degree >= 0;
  bool fbar = false;
  try
  {
    fbar = use_fbar(scene.mesh.fbar, cell_type, scene.mesh.degree, anti_locking);
  }
  catch (const InputError& e)
  {
    throw InputError(scene.mesh.fbar_where.text() + ": " + e.what());
  }
  const Discretisation element{scene.mesh.degree, scene.mesh.quadrature_degree,
                               scene.mesh.volumetric_quadrature_degree, fbar};
  std::vector<std::string> warnings;
  for (const Part& part : scene.parts)
    if (std::string w = locking_warning(cell_type, scene.mesh.degree, fbar, anti_locking,
                                        part.parameters);
        !w.empty())
    {
      warnings.push_back(part.where.text() + ": " + w);
      if (is_root())
        std::fprintf(stderr, "warning: %s\n", warnings.back().c_str());
    }

  auto surface = [&](const std::string& name, const SceneLocation& where)
  {
    try
    {
      return gm.surface(name);
    }
    catch (const InputError& e)
    {
      throw InputError(where.text() + ": " + e.what());
    }
  };

  // The materials, one problem per part (several parts share the first one's
  // displacement and integrate over their own cells): passive forms for a
  // passive part, the activation kernel only for WKM/GIANT, the twitch train
  // only if the time function asks for it
  const auto part_tags = assign_parts(scene, gm);
  std::vector<std::unique_ptr<MuscleProblem>> problems;
  std::vector<MuscleProblem*> body;
  std::vector<std::unique_ptr<ScaleField>> scales;
  std::vector<bool> model_time;
  for (std::size_t p = 0; p < scene.parts.size(); ++p)
  {
    const Part& part = scene.parts[p];
    std::optional<CellRegion> region;
    if (part_tags)
      region = CellRegion{part_tags, static_cast<int>(p) + 1};
    try
    {
      problems.push_back(std::make_unique<MuscleProblem>(
          mesh, part.parameters, element, !part.active, region,
          p > 0 ? problems[0]->u() : nullptr));
    }
    catch (const InputError& e)
    {
      throw InputError(scene.file + ": element: " + e.what());
    }
    body.push_back(problems.back().get());
    set_fibres(part.fibres, gm, *problems.back(), surface);
    scales.push_back(part.active ? std::make_unique<ScaleField>(
                                       part.activation_scale, gm,
                                       *problems.back()->activation_scale(),
                                       problems.back()->cells())
                                 : nullptr);
    model_time.push_back(part.active
                         and part.activation_time.kind == TimeFunction::Kind::model);
  }
  MuscleProblem& problem = *problems[0]; // holds the displacement
  const MuscleProblem* first_active = nullptr;
  for (std::size_t p = 0; p < body.size() and !first_active; ++p)
    if (scene.parts[p].active)
      first_active = body[p];
  auto total_volume = [&]
  {
    double v = 0;
    for (const MuscleProblem* part : body)
      v += part->volume();
    return v;
  };

  // Boundary conditions
  auto V = problem.V();
  std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs;
  std::vector<std::pair<std::shared_ptr<fem::Constant<double>>, const BoundaryCondition*>> moving;
  std::shared_ptr<DisplacementConstraint> constraint;
  std::set<std::string> supports; // surfaces with Dirichlet values (reactions)
  std::vector<std::array<double, 3>> fixed_points; // nodes of fix_point
  for (const BoundaryCondition& bc : scene.boundary)
  {
    if (bc.kind == BoundaryCondition::Kind::point)
    {
      // a point inside the body (or within half an element of it): its nearest node
      const PointProbe probe(problem.u(), bc.at);
      const double size = std::cbrt(total_volume() / std::max<std::int64_t>(gm.num_cells, 1));
      if (probe.distance() > 0.5 * size)
        throw InputError(bc.where.text() + ".fix_point: (" + std::to_string(bc.at[0]) + ", "
                         + std::to_string(bc.at[1]) + ", " + std::to_string(bc.at[2])
                         + ") lies " + std::to_string(probe.distance())
                         + " mm outside the body, more than half an element");
      std::array<double, 3> node;
      bcs.push_back(fix_nearest_node(V, bc.at, node));
      fixed_points.push_back(node);
      continue;
    }
    const auto facets = tagged_facets(*gm.facet_tags, surface(bc.surface, bc.where));
    supports.insert(bc.surface);
    if (bc.kind == BoundaryCondition::Kind::clamp)
      bcs.push_back(clamp(V, facets));
    else if (bc.kind == BoundaryCondition::Kind::displacement)
    {
      auto value = std::make_shared<fem::Constant<double>>(bc.value(0.0));
      moving.push_back({value, &bc});
      bcs.push_back(prescribe_component(V, facets, bc.component, value));
    }
    else
      constraint = std::make_shared<UniformDisplacementConstraint>(
          *V, component_dofs(*V, facets, bc.component));
  }

  // Ties of separately meshed bodies: one constraint for all pairs (none without ties)
  std::shared_ptr<TieConstraint> tie;
  if (!scene.ties.empty())
  {
    if (constraint)
      throw InputError(scene.ties[0].where.text()
                       + ": a tie and a uniform_axial condition in one scene are not "
                         "supported; use one of them");
    const double size = std::cbrt(total_volume() / std::max<std::int64_t>(gm.num_cells, 1));
    std::vector<TieConstraint::Pair> pairs;
    for (std::size_t i = 0; i < scene.ties.size(); ++i)
    {
      const TieSpec& t = scene.ties[i];
      pairs.push_back({t.where.text(), tagged_facets(*gm.facet_tags, surface(t.slave, t.where)),
                       tagged_facets(*gm.facet_tags, surface(t.master, t.where)),
                       t.tolerance > 0 ? t.tolerance : 0.25 * size});
    }
    std::vector<std::int32_t> fixed;
    for (const auto& bc : bcs)
      fixed.insert(fixed.end(), bc->dof_indices().first.begin(), bc->dof_indices().first.end());
    std::sort(fixed.begin(), fixed.end());
    tie = std::make_shared<TieConstraint>(*V, pairs, fixed);
    constraint = tie;
  }

  // Contact pairs (none without contact)
  std::vector<std::shared_ptr<ContactPair>> contacts;
  nlohmann::json built_contacts = nlohmann::json::array();
  if (!scene.contacts.empty())
  {
    const double size = std::cbrt(total_volume() / std::max<std::int64_t>(gm.num_cells, 1));
    // the default penalty: 10 x the stiffest part's tangent at rest per element size
    double stiffness = 0;
    for (const Part& part : scene.parts)
    {
      MaterialPointModel m(part.parameters);
      m.set_time_factor(0);
      stiffness = std::max(stiffness, m.tangent(MaterialPoint{})[0]);
    }
    std::vector<std::int32_t> fixed;
    for (const auto& bc : bcs)
      fixed.insert(fixed.end(), bc->dof_indices().first.begin(), bc->dof_indices().first.end());
    std::sort(fixed.begin(), fixed.end());
    for (std::size_t i = 0; i < scene.contacts.size(); ++i)
    {
      const ContactSpec& c = scene.contacts[i];
      const double eps = c.penalty > 0 ? c.penalty : 10 * stiffness / size;
      contacts.push_back(std::make_shared<ContactPair>(
          problem.u(),
          ContactPair::Settings{c.where.text(),
                                tagged_facets(*gm.facet_tags, surface(c.slave, c.where)),
                                tagged_facets(*gm.facet_tags, surface(c.master, c.where)), eps,
                                size, c.smooth_normals},
          fixed));
      built_contacts.push_back({{"pair", c.slave + " on " + c.master},
                                {"penalty", eps},
                                {"penalty_default", !(c.penalty > 0)},
                                {"normals", c.smooth_normals ? "smooth" : "facet"}});
      if (!options.quiet and is_root())
        std::printf("contact[%zu] %s on %s: penalty %.6g kPa/mm%s\n", i, c.slave.c_str(),
                    c.master.c_str(), eps,
                    c.penalty > 0 ? "" : " (10 x the stiffest tangent / element size)");
    }
  }

  // External loads: forms of their own, only when the scene has loads
  std::unique_ptr<Loads> loads;
  if (!scene.loads.empty())
  {
    loads = std::make_unique<Loads>(problem.u());
    const auto exterior = mesh::exterior_facet_indices(mesh->topology());
    const std::int32_t owned_facets = mesh->topology().index_map(2)->size_local();
    for (const LoadSpec& l : scene.loads)
    {
      auto value = [&l](double t) { return l.value(t); };
      if (l.kind == LoadSpec::Kind::gravity)
      {
        auto cell_map = mesh->topology().index_map(3);
        std::vector<double> density(cell_map->size_local() + cell_map->num_ghosts(), 0.0);
        for (std::size_t p = 0; p < body.size(); ++p)
          for (std::int32_t c : body[p]->cells())
            density[c] = scene.parts[p].density;
        loads->add_gravity(l.vector, value, density);
        continue;
      }
      const auto facets = tagged_facets(*gm.facet_tags, surface(l.surface, l.where));
      std::int64_t inner = std::count_if(
          facets.begin(), facets.end(), [&](std::int32_t f)
          { return f < owned_facets and !std::binary_search(exterior.begin(), exterior.end(), f); });
      MPI_Allreduce(MPI_IN_PLACE, &inner, 1, MPI_INT64_T, MPI_SUM, mesh->comm());
      if (inner > 0)
        throw InputError(l.where.text() + ": '" + l.surface + "' has " + std::to_string(inner)
                         + " facets inside the body; a load acts on the boundary");
      if (l.kind == LoadSpec::Kind::pressure)
        loads->add_pressure(l.surface, facets, value);
      else
        loads->add_traction(l.surface, facets, l.vector, value);
    }
  }

  // Series quantities
  la::Vector<double> nodal(V->dofmap()->index_map, V->dofmap()->index_map_bs());
  const double volume0 = total_volume();
  std::vector<std::function<double()>> measure;
  std::vector<std::shared_ptr<fem::Form<double>>> keep_forms;
  std::vector<std::shared_ptr<mesh::MeshTags<std::int32_t>>> keep_tags;
  bool need_nodal_forces = false;
  for (const SeriesQuantity& q : scene.output.series)
  {
    using K = SeriesQuantity::Kind;
    std::vector<std::int32_t> dofs;
    if (!q.surface.empty())
      dofs = component_dofs(*V, tagged_facets(*gm.facet_tags, surface(q.surface, q.where)),
                            q.component);
    std::int64_t count = dofs.size(), total = 0;
    const std::int32_t owned = V->dofmap()->index_map->size_local() * 3;
    count = std::count_if(dofs.begin(), dofs.end(), [&](auto d) { return d < owned; });
    MPI_Allreduce(&count, &total, 1, MPI_INT64_T, MPI_SUM, mesh->comm());
    switch (q.kind)
    {
    case K::activation:
      measure.push_back([first_active] { return first_active ? first_active->time_factor() : 0.0; });
      break;
    case K::reaction:
      if (!supports.count(q.surface))
        throw InputError(q.where.text() + ": '" + q.surface
                         + "' carries no boundary condition, so there is no reaction; use "
                           "section_force for an interior surface");
      need_nodal_forces = true;
      measure.push_back([&nodal, dofs] { return -sum_owned(nodal, dofs); });
      break;
    case K::section_force:
    {
      // the residual of the cells on one side of the surface, summed over its
      // nodes; the side is decided along the surface's normal axis, so the
      // surface must be a plane x, y or z = const
      const auto facets = tagged_facets(*gm.facet_tags, surface(q.surface, q.where));
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
      for (std::size_t p = 0; p < body.size(); ++p)
      {
        std::vector<std::int32_t> side(cells.size());
        for (std::size_t c = 0; c < cells.size(); ++c)
          side[c] = (cm[3 * c + normal] < level) == (q.sign > 0)
                            and (!part_tags or part_tags->values()[c] == int(p) + 1)
                        ? 1
                        : 2;
        auto tags = std::make_shared<mesh::MeshTags<std::int32_t>>(mesh, 3, cells, side);
        forms.push_back(body[p]->residual_on_cells(tags, 1));
        keep_tags.push_back(tags);
        keep_forms.push_back(forms.back());
      }
      const double sign = q.sign;
      measure.push_back(
          [&nodal, forms, dofs, sign]
          {
            la::Vector<double> b(nodal.map(), nodal.bs());
            for (const auto& form : forms)
              fem::assemble_vector<double>(b.mutable_array(), *form);
            b.scatter_rev(std::plus<double>());
            return sign * sum_owned(b, dofs);
          });
      break;
    }
    case K::displacement:
    case K::stretch_ratio:
    {
      const double length = q.kind == K::stretch_ratio ? q.length : 0;
      auto u = problem.u();
      measure.push_back(
          [u, dofs, total, length]
          {
            const double mean = sum_owned(*u->x(), dofs) / std::max<std::int64_t>(total, 1);
            return length > 0 ? 1 + mean / length : mean;
          });
      break;
    }
    case K::volume_change:
      measure.push_back([&, volume0] { return total_volume() / volume0 - 1; });
      break;
    case K::min_J:
      measure.push_back(
          [&]
          {
            double local = std::numeric_limits<double>::infinity();
            for (const MuscleProblem* part : body)
              local = std::min(local, part->min_jacobian_determinant().first);
            double global = 0;
            MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, mesh->comm());
            return global;
          });
      break;
    case K::rotation:
    {
      std::size_t p = 0;
      while (p < scene.parts.size() and scene.parts[p].name != q.part)
        ++p;
      if (p == scene.parts.size())
      {
        std::vector<std::string> names;
        for (const Part& part : scene.parts)
          names.push_back(part.name);
        throw InputError(q.where.text() + ".part: no part named '" + q.part + "'; parts: "
                         + join(names));
      }
      const MuscleProblem* part = body[p];
      const int c = q.component;
      measure.push_back([&problem, part, c]
                        { return rotation_vector(*problem.u(), part->cells())[c]; });
      break;
    }
    case K::contact_force:
    case K::contact_area:
    case K::max_pressure:
    case K::max_penetration:
    {
      if (q.pair >= static_cast<int>(contacts.size()))
        throw InputError(q.where.text() + ".pair: " + std::to_string(q.pair)
                         + " names no contact pair; the scene has "
                         + std::to_string(contacts.size()));
      auto pair = contacts[q.pair];
      const K kind = q.kind;
      measure.push_back(
          [pair, kind]
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
          });
      break;
    }
    case K::point:
    {
      auto probe = std::make_shared<PointProbe>(problem.u(), q.at);
      const double size = std::cbrt(volume0 / std::max<std::int64_t>(gm.num_cells, 1));
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
      measure.push_back([probe, c, offset] { return offset + probe->displacement()[c]; });
      break;
    }
    }
  }

  const std::int64_t unknowns = constraint ? constraint->reduced_size()
                                           : V->dofmap()->index_map->size_global() * 3;
  // what each part built; the first part's at the top level
  nlohmann::json built_parts = nlohmann::json::array();
  std::string forms_text;
  for (std::size_t p = 0; p < body.size(); ++p)
  {
    const Part& part = scene.parts[p];
    built_parts.push_back(
        {{"part", part.name},
         {"forms", body[p]->kernel_name()},
         {"activation_terms", part.active},
         {"activation_kernel", body[p]->has_activation_kernel()},
         {"twitch_train", model_time[p] and uses_twitch_train(part.parameters.model())}});
    forms_text += (p ? ", " : "") + body[p]->kernel_name()
                  + (body[p]->has_activation_kernel() ? " + activation kernel" : "");
  }
  nlohmann::json built = built_parts[0];
  built.erase("part");
  built["axial_constraint_unknown"] = constraint != nullptr and !tie;
  built["loads"] = loads ? loads->describe() : std::vector<std::string>{};
  built["fixed_points"] = fixed_points;
  built["contact"] = built_contacts;
  built["line_search"] = !contacts.empty() and !scene.line_search_given ? std::string("bt")
                                                                        : scene.newton.line_search;
  built["tie_slave_nodes"] = tie ? tie->slave_nodes() : 0;
  if (tie)
    built["tie_largest_gap"] = tie->largest_gap();
  built["mass_matrix"] = false;
  built["element"] = {{"cell", cell_type}, {"degree", scene.mesh.degree}, {"fbar", fbar}};
  built["unknowns"] = unknowns;
  if (body.size() > 1)
    built["parts"] = built_parts;
  if (!options.quiet and is_root())
    std::printf("%s: %s, %lld cells, %lld unknowns, %s%s degree %d, forms %s\n",
                scene.file.c_str(), scene.title.c_str(), static_cast<long long>(gm.num_cells),
                static_cast<long long>(unknowns), fbar ? "F-bar " : "", cell_type.c_str(),
                scene.mesh.degree, forms_text.c_str());

  nlohmann::json assembly;
  if (options.measure_assembly > 0 and body.size() > 1)
    throw InputError("--measure-assembly compares one part's forms with the plain passive "
                     "forms; this scene has " + std::to_string(body.size()) + " parts");
  if (options.measure_assembly > 0)
  {
    // the (first) part's forms against the plain passive forms of the same model
    const Part& part = scene.parts[0];
    problem.set_time_factor(part.active ? 1.0 : 0.0);
    assembly["scene"] = time_assembly(problem, options.measure_assembly);
    MuscleProblem plain(mesh, part.parameters, element, true);
    assembly["plain_passive"] = time_assembly(plain, options.measure_assembly);
    problem.set_time_factor(0);
    if (is_root())
      for (const char* k : {"scene", "plain_passive"})
        std::printf("assembly (%s, %s): residual %.4f s, Jacobian %.4f s, activation kernel "
                    "%.4f s (median of %d)\n",
                    k, assembly[k]["forms"].get<std::string>().c_str(),
                    assembly[k]["residual_s"].get<double>(), assembly[k]["jacobian_s"].get<double>(),
                    assembly[k]["activation_kernel_s"].get<double>(), options.measure_assembly);
  }
  const double setup_time = seconds_since(start); // mesh, fibres, forms, constraint

  // Time stepping state, from a checkpoint when resuming
  TimeSteppingOptions stepping = scene.time;
  int step = 0, total_newton = 0, total_linear = 0, total_cutbacks = 0;
  double previous_wall = 0;
  const std::string series_path = options.out + "/series.csv";
  if (options.resume)
  {
    const nlohmann::json state = read_checkpoint(*problem.u(), options.out);
    if (state.value("scene_fingerprint", std::size_t(0)) != fingerprint(scene.physics))
      throw InputError("--resume: the scene's mesh, element, parts (materials, data files) or "
                       "boundary changed since the checkpoint in " + options.out + " was "
                       "written (time, solver and output settings may change); run without "
                       "--resume to start afresh");
    std::vector<std::string> columns;
    for (const SeriesQuantity& q : scene.output.series)
      columns.push_back(q.name);
    if (state.value("series_columns", std::vector<std::string>{}) != columns)
      throw InputError("--resume: output.series changed since the checkpoint in " + options.out
                       + " (columns now: " + join(columns) + "); keep the series columns to "
                       "continue the same series.csv");
    step = state.at("step");
    stepping.t_start = state.at("t");
    stepping.first_substep = state.at("next_substep");
    stepping.first_successes = state.at("successes");
    total_newton = state.at("newton_iterations");
    total_linear = state.at("linear_iterations");
    total_cutbacks = state.at("cutbacks");
    previous_wall = state.at("wall_time");
    if (is_root())
    {
      // keep the series up to the checkpoint
      std::ifstream in(series_path);
      std::vector<std::string> lines;
      for (std::string line; std::getline(in, line) and lines.size() < std::size_t(step) + 1;)
        lines.push_back(line);
      std::ofstream out(series_path);
      for (const auto& line : lines)
        out << line << "\n";
    }
    if (!options.quiet and is_root())
      std::printf("resuming at t = %.6g s (step %d)\n", stepping.t_start, step);
  }

  // Activation and boundary values at t, checked wherever the stepper goes
  // (also at sub-steps after a cutback): a user formula must never feed a
  // negative activation or a NaN displacement to the solver
  auto set_time = [&](double t)
  {
    for (std::size_t p = 0; p < body.size(); ++p)
    {
      const Part& part = scene.parts[p];
      if (!part.active)
        continue;
      const double model_factor = model_time[p] ? time_factor(part.parameters, t) : 0.0;
      const double a = part.activation_time(t, model_factor);
      if (!(std::isfinite(a) and a >= 0))
        throw InputError(part.where.text() + ": activation.time is " + std::to_string(a)
                         + " at t = " + std::to_string(t) + "; it must be finite and >= 0");
      body[p]->set_time_factor(a);
      scales[p]->update(t); // checks itself on every rank
    }
    for (auto& [constant, bc] : moving)
    {
      constant->value = {bc->value(t)};
      if (!std::isfinite(constant->value[0]))
        throw InputError(bc->where.text() + ": the prescribed displacement is "
                         + std::to_string(constant->value[0]) + " at t = " + std::to_string(t));
    }
    for (const LoadSpec& l : scene.loads)
      if (!std::isfinite(l.value(t)))
        throw InputError(l.where.text() + ": the load's value is " + std::to_string(l.value(t))
                         + " at t = " + std::to_string(t));
    if (loads)
      loads->set_time(t);
  };
  // ... and at every output time before the first solve: a negative
  // activation at t = 0.1 s should not cost a run to 0.1 s
  const int remaining_steps = static_cast<int>(
      std::ceil((stepping.t_end - stepping.t_start) / stepping.dt - 1e-9));
  for (int k = 0; k <= remaining_steps; ++k)
    set_time(std::min(stepping.t_start + k * stepping.dt, stepping.t_end));
  if (options.check_only)
    return;
  set_time(stepping.t_start);
  // Contact makes the energy along a Newton direction kinked where points enter
  // or leave contact, and the critical-point line search struggles there.
  // Measured (Hertz scene, 2 steps): cp 33 Newton iterations + 1 cutback (54 s),
  // basic 29 + 1 (48 s), bt 19 (35 s); sliding blocks: basic diverges, cp and bt
  // converge.  So bt with contact unless the scene chooses.
  NewtonOptions newton = scene.newton;
  if (!contacts.empty() and !scene.line_search_given)
    newton.line_search = "bt";
  NonlinearSolver solver(body, bcs, constraint, newton);
  if (loads)
    solver.add_forms(loads->residuals(), loads->jacobians());
  for (const auto& c : contacts)
    solver.add_term(c);
  solver.restore_displacement();
  QuasiStaticStepper stepper(problem, solver, set_time, stepping);

  // Outputs
  std::ofstream series;
  if (is_root())
  {
    series.open(series_path, options.resume ? std::ios::app : std::ios::trunc);
    series.precision(12);
    if (!options.resume)
    {
      series << "t";
      for (const SeriesQuantity& q : scene.output.series)
        series << "," << q.name;
      series << ",newton_iterations,linear_iterations,cutbacks,residual,wall_time\n";
    }
  }
  // Output fields of the whole body: each part fills its own cells
  auto body_post = [&]
  {
    MuscleProblem::PostFields sum = body[0]->post_fields();
    for (std::size_t p = 1; p < body.size(); ++p)
    {
      const MuscleProblem::PostFields more = body[p]->post_fields();
      auto add = [](auto& to, const auto& from)
      {
        std::span<double> x = to->x()->mutable_array();
        std::span<const double> y = from->x()->array();
        for (std::size_t i = 0; i < x.size(); ++i)
          x[i] += y[i];
      };
      const auto to = sum.all(), from = more.all();
      for (std::size_t k = 0; k < to.size(); ++k)
        add(to[k], from[k]);
    }
    return sum;
  };
  auto fibre = problem.fibre();
  if (body.size() > 1)
  {
    fibre = std::make_shared<fem::Function<double>>(problem.fibre()->function_space());
    fibre->name = "fibre";
    const auto& dofmap = *fibre->function_space()->dofmap();
    std::span<double> out = fibre->x()->mutable_array();
    for (const MuscleProblem* part : body)
    {
      std::span<const double> in = part->fibre()->x()->array();
      for (std::int32_t c : part->cells())
        for (int k = 0; k < 3; ++k)
          out[3 * dofmap.cell_dofs(c)[0] + k] = in[3 * dofmap.cell_dofs(c)[0] + k];
    }
  }

  // A killed run leaves its HDF5 file unclosed (unreadable for appending):
  // a resumed run writes its fields to a file of its own.
  std::unique_ptr<io::XDMFFile> xdmf;
  const std::string fields_path
      = options.out + (options.resume ? "/fields_from_step" + std::to_string(step) + ".xdmf"
                                      : "/fields.xdmf");
  if (scene.output.fields)
  {
    xdmf = std::make_unique<io::XDMFFile>(mesh->comm(), fields_path, "w");
    xdmf->write_mesh(*mesh);
    xdmf->write_function(*fibre, stepping.t_start);
  }
  std::unique_ptr<ContactFields> contact_fields;
  if (!contacts.empty())
    contact_fields = std::make_unique<ContactFields>(*problem.u()->function_space());
  auto write_fields = [&](double t)
  {
    if (!xdmf)
      return;
    xdmf->write_function(*problem.u(), t);
    const MuscleProblem::PostFields post = body_post();
    for (const auto& f : post.all())
      xdmf->write_function(*f, t);
    if (contact_fields)
    {
      contact_fields->update(contacts);
      xdmf->write_function(*contact_fields->pressure, t);
      xdmf->write_function(*contact_fields->gap, t);
    }
  };
  if (!options.resume)
    write_fields(0.0);
  else
    write_fields(stepping.t_start);

  const int steps = step + remaining_steps;
  std::vector<std::string> series_columns;
  for (const SeriesQuantity& q : scene.output.series)
    series_columns.push_back(q.name);
  const int first_step = step;
  // the quantities at the start (a resumed run with nothing left to do reports these)
  std::vector<double> last(scene.output.series.size(), 0.0);
  if (need_nodal_forces)
    solver.assemble_nodal_forces(nodal);
  for (std::size_t k = 0; k < measure.size(); ++k)
    last[k] = measure[k]();
  const auto stepping_start = Clock::now();
  double output_time = 0; // series, fields, checkpoints
  std::optional<StepFailure> failure;
  std::string input_error; // a formula gone bad at a sub-step
  try
  {
  failure = stepper.run(
      [&](const StepRecord& r)
      {
        ++step;
        total_newton += r.newton_iterations;
        total_linear += r.linear_iterations;
        total_cutbacks += r.cutbacks;
        const auto output_start = Clock::now();
        if (need_nodal_forces)
          solver.assemble_nodal_forces(nodal);
        for (std::size_t k = 0; k < measure.size(); ++k)
          last[k] = measure[k]();
        const double elapsed = previous_wall + seconds_since(start);
        if (is_root())
        {
          series << r.t;
          for (double v : last)
            series << "," << v;
          series << "," << r.newton_iterations << "," << r.linear_iterations << ","
                 << r.cutbacks << "," << r.residual << "," << elapsed << std::endl;
        }
        if (!options.quiet and is_root())
        {
          std::string values;
          for (std::size_t k = 0; k < last.size() and k < 3; ++k)
          {
            char text[64];
            std::snprintf(text, sizeof text, "  %s=%.6g", scene.output.series[k].name.c_str(),
                          last[k]);
            values += text;
          }
          const double run_time = seconds_since(start);
          std::printf("t=%.4f s  step %d/%d  newton %2d  |R|=%.1e%s%s  %.1f s, ETA %.0f s\n",
                      r.t, step, steps, r.newton_iterations, r.residual, values.c_str(),
                      r.cutbacks ? ("  (" + std::to_string(r.cutbacks) + " cutbacks)").c_str()
                                 : "",
                      elapsed, run_time / (step - first_step) * (steps - step));
          std::fflush(stdout);
        }
        if (step % scene.output.fields_every == 0 or step == steps)
          write_fields(r.t);
        if (step % scene.output.checkpoint_every == 0 or step == steps)
          write_checkpoint(*problem.u(), options.out,
                           {{"step", step}, {"t", r.t}, {"next_substep", r.next_substep},
                            {"successes", r.successes}, {"newton_iterations", total_newton},
                            {"linear_iterations", total_linear}, {"cutbacks", total_cutbacks},
                            {"wall_time", elapsed},
                            {"scene_fingerprint", fingerprint(scene.physics)},
                            {"series_columns", series_columns}});
        output_time += seconds_since(output_start);
        return true;
      });
  }
  catch (const InputError& e)
  {
    input_error = e.what();
  }

  const double stepping_time = seconds_since(stepping_start);
  if (failure and failure->reason.find("non-finite") != std::string::npos)
  {
    // an overflowing input, not the step, is the usual cause: name the largest
    // activation scale (collective)
    for (std::size_t p = 0; p < scales.size(); ++p)
      if (scales[p])
      {
        char largest[32];
        std::snprintf(largest, sizeof largest, "%.6g", scales[p]->largest());
        failure->where += "; activation scale of part '" + scene.parts[p].name + "' up to "
                          + largest + " ("
                          + scene.parts[p].activation_scale.where.text() + ")";
      }
  }
  // The last converged state is kept whatever happened
  if (scene.output.surface)
  {
    const MuscleProblem::PostFields post = body_post();
    const auto fields = post.all();
    std::vector<std::shared_ptr<const fem::Function<double>>> more(fields.begin(), fields.end());
    if (contact_fields)
    {
      contact_fields->update(contacts);
      more.insert(more.end(), {contact_fields->pressure, contact_fields->gap});
    }
    export_deformed_surface(*problem.u(), *post.fibre_stretch, options.out + "/surface.json",
                            more);
  }
  if (is_root())
  {
    nlohmann::json summary = {
        {"scene", scene.file}, {"title", scene.title},
        {"model", to_string(scene.parts[0].parameters.model())},
        {"cells", gm.num_cells}, {"nodes", gm.num_nodes}, {"degree", scene.mesh.degree},
        {"dt", scene.time.dt}, {"t_end", scene.time.t_end}, {"steps", step},
        {"newton_iterations", total_newton}, {"linear_iterations", total_linear},
        {"cutbacks", total_cutbacks}, {"wall_time", previous_wall + seconds_since(start)},
        {"resumed", options.resume}, {"ranks", dolfinx::MPI::size(MPI_COMM_WORLD)},
        {"completed", !failure and input_error.empty()}, {"built", built},
        {"timings", {{"setup_s", setup_time},
                     {"solve_s", stepping_time - output_time},
                     {"output_s", output_time}}},
        {"fields", scene.output.fields ? fields_path : ""},
        {"overrides", scene.overrides}, {"warnings", warnings}};
    for (std::size_t k = 0; k < last.size(); ++k)
      summary["final"][scene.output.series[k].name] = last[k];
    if (!assembly.is_null())
      summary["assembly"] = assembly;
    if (!input_error.empty())
      summary["failure"] = {{"reason", input_error}};
    if (failure)
      summary["failure"] = failure->to_json();
    std::ofstream(options.out + "/summary.json") << summary.dump(1) << "\n";
  }
  if (series.is_open())
    series.close();
  if (!input_error.empty())
    throw InputError(input_error + " (the state at the last converged step is written to "
                     + options.out + ")");
  if (failure)
    throw SolveError(failure->message(step + 1, options.out));
}

} // namespace muscle
