#include "scene/scene_model.h"

#include "common/application.h"
#include "common/errors.h"
#include "fem/constraints/boundary.h"
#include "fem/elements/element_choice.h"
#include "fem/analysis/point_probe.h"
#include "fem/linear/rigid_body_modes.h"
#include "fem/constraints/uniform_constraint.h"
#include "material/material_point.h"
#include "material/time_functions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <dolfinx/mesh/utils.h>
#include <map>
#include <numeric>

using namespace dolfinx;

namespace muscle
{

std::vector<std::int32_t> all_cells(const mesh::Mesh& mesh)
{
  auto map = mesh.topology().index_map(3);
  std::vector<std::int32_t> cells(map->size_local() + map->num_ghosts());
  std::iota(cells.begin(), cells.end(), 0);
  return cells;
}

double SceneModel::volume() const
{
  double v = 0;
  for (const MuscleProblem* part : body)
    v += part->volume();
  return v;
}

double SceneModel::element_size() const
{
  return std::cbrt(volume() / std::max<std::int64_t>(gm.num_cells, 1));
}

int SceneModel::surface(const std::string& name, const SceneLocation& where) const
{
  try
  {
    return gm.surface(name);
  }
  catch (const InputError& e)
  {
    throw InputError(where.text() + ": " + e.what());
  }
}

std::vector<std::int32_t> SceneModel::facets(const std::string& name,
                                             const SceneLocation& where) const
{
  return tagged_facets(*gm.facet_tags, surface(name, where));
}

std::vector<std::int32_t> SceneModel::fixed_dofs() const
{
  std::vector<std::int32_t> fixed;
  for (const auto& bc : bcs)
    fixed.insert(fixed.end(), bc->dof_indices().first.begin(), bc->dof_indices().first.end());
  std::sort(fixed.begin(), fixed.end());
  return fixed;
}

std::vector<std::shared_ptr<fem::Function<double>>> SceneModel::state() const
{
  std::vector<std::shared_ptr<fem::Function<double>>> fields = {problem().u()};
  if (dynamics)
    for (auto& f : dynamics->state())
      fields.push_back(f);
  return fields;
}

std::int64_t SceneModel::unknowns() const
{
  std::int64_t n = constraint ? constraint->reduced_size()
                              : problem().V()->dofmap()->index_map->size_global() * 3;
  if (problem().taylor_hood()) // theta and p on the degree-1 nodes
    n += problem().th_state()->function_space()->dofmap()->index_map->size_global() * 2;
  return n;
}

SceneModel read_mesh(const Scene& scene)
{
  SceneModel model;
  try
  {
    model.gm = read_gmsh(MPI_COMM_WORLD, scene.mesh.path, scene.mesh.numbers);
  }
  catch (const InputError& e)
  {
    // located at the scene's mesh key: the numbers that made it come from there
    throw InputError((scene.mesh.numbers.empty() ? scene.mesh.where
                                                  : scene.mesh.numbers_where).text()
                     + ": " + e.what());
  }
  return model;
}

void choose_element(const Scene& scene, SceneModel& model)
{
  const std::string cell_type = mesh::to_string(model.gm.mesh->topology().cell_type());
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
  model.cell_type = cell_type;
  model.element = {scene.mesh.degree, scene.mesh.quadrature_degree,
                   scene.mesh.volumetric_quadrature_degree, fbar, scene.mesh.taylor_hood};
  for (const Part& part : scene.parts)
    if (std::string w = locking_warning(cell_type, scene.mesh.degree, fbar, anti_locking,
                                        part.parameters);
        !w.empty())
    {
      model.warnings.push_back(part.where.text() + ": " + w);
      if (is_root())
        std::fprintf(stderr, "warning: %s\n", model.warnings.back().c_str());
    }
}

namespace
{
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

void add_parts(const Scene& scene, SceneModel& model)
{
  // passive forms for a passive part, the activation kernel only for WKM/GIANT,
  // the twitch train only if the time function asks for it
  model.part_tags = assign_parts(scene, model.gm);
  for (std::size_t p = 0; p < scene.parts.size(); ++p)
  {
    const Part& part = scene.parts[p];
    std::optional<CellRegion> region;
    if (model.part_tags)
      region = CellRegion{model.part_tags, static_cast<int>(p) + 1};
    try
    {
      model.problems.push_back(std::make_unique<MuscleProblem>(
          model.gm.mesh, part.parameters, model.element, !part.active, region,
          p > 0 ? model.problems[0]->u() : nullptr));
    }
    catch (const InputError& e)
    {
      throw InputError(scene.file + ": element: " + e.what());
    }
    MuscleProblem& problem = *model.problems.back();
    problem.set_root_tolerance(scene.root_tolerance);
    model.body.push_back(&problem);
    set_fibres(part.fibres, model, problem);
    model.scales.push_back(part.active ? std::make_unique<ScaleField>(
                                             part.activation_scale, model.gm,
                                             *problem.activation_scale(), problem.cells())
                                       : nullptr);
    model.model_time.push_back(part.active
                               and part.activation_time.kind == TimeFunction::Kind::model);
  }
}

namespace
{
/// A dof both prescribed and tied by uniform_axial: T^T J T would sum its unit
/// Dirichlet row into the tied value's equation, and the run would move (or hold)
/// the whole surface by one node's condition without a word.
void refuse_prescribed_tied_dofs(const SceneModel& model,
                                 const std::vector<const BoundaryCondition*>& prescribing,
                                 const BoundaryCondition& uniform)
{
  const std::vector<std::int64_t> reduced = model.constraint->reduced_numbers();
  for (std::size_t i = 0; i < prescribing.size(); ++i)
  {
    auto [dofs, owned] = model.bcs[i]->dof_indices();
    std::int64_t shared = std::count_if(dofs.begin(), dofs.begin() + owned,
                                        [&](std::int32_t d) { return reduced[d] < 0; });
    MPI_Allreduce(MPI_IN_PLACE, &shared, 1, MPI_INT64_T, MPI_SUM,
                  model.problem().mesh()->comm());
    if (shared == 0)
      continue;
    const BoundaryCondition& bc = *prescribing[i];
    const std::string what = bc.kind == BoundaryCondition::Kind::point ? "fix_point"
                             : bc.kind == BoundaryCondition::Kind::clamp
                                 ? "clamp: " + bc.surface
                                 : "displacement: " + bc.surface;
    throw InputError(uniform.where.text() + ": uniform_axial: " + uniform.surface + " ties "
                     + std::to_string(shared) + " displacement component"
                     + (shared > 1 ? "s" : "") + " that " + bc.where.text() + " (" + what
                     + ") prescribes; a tied component cannot also be prescribed. Let the "
                       "surfaces share no node in component "
                     + std::string(1, "xyz"[uniform.component]) + ", or prescribe the "
                       "whole surface instead of tying it");
  }
}
} // namespace

void add_boundary(const Scene& scene, SceneModel& model)
{
  auto V = model.problem().V();
  // model.bcs[i] comes from prescribing[i]
  std::vector<const BoundaryCondition*> prescribing;
  const BoundaryCondition* uniform = nullptr;
  for (const BoundaryCondition& bc : scene.boundary)
  {
    if (bc.kind == BoundaryCondition::Kind::uniform_axial)
      uniform = &bc;
    else
      prescribing.push_back(&bc);
    if (bc.kind == BoundaryCondition::Kind::point)
    {
      // a point inside the body (or within half an element of it): its nearest node
      const PointProbe probe(model.problem().u(), bc.at);
      const double size = model.element_size();
      if (probe.distance() > 0.5 * size)
        throw InputError(bc.where.text() + ".fix_point: (" + std::to_string(bc.at[0]) + ", "
                         + std::to_string(bc.at[1]) + ", " + std::to_string(bc.at[2])
                         + ") lies " + std::to_string(probe.distance())
                         + " mm outside the body, more than half an element");
      std::array<double, 3> node;
      model.bcs.push_back(fix_nearest_node(V, bc.at, node));
      model.fixed_points.push_back(node);
      continue;
    }
    const auto facets = model.facets(bc.surface, bc.where);
    model.supports.insert(bc.surface);
    if (bc.kind == BoundaryCondition::Kind::clamp)
      model.bcs.push_back(clamp(V, facets));
    else if (bc.kind == BoundaryCondition::Kind::displacement)
    {
      auto value = std::make_shared<fem::Constant<double>>(bc.value(0.0));
      model.moving.push_back({value, &bc});
      model.bcs.push_back(prescribe_component(V, facets, bc.component, value));
    }
    else
      model.constraint = std::make_shared<UniformDisplacementConstraint>(
          *V, component_dofs(*V, facets, bc.component));
  }
  if (uniform)
    refuse_prescribed_tied_dofs(model, prescribing, *uniform);
}

void add_ties(const Scene& scene, SceneModel& model)
{
  if (scene.ties.empty())
    return;
  if (model.constraint)
    throw InputError(scene.ties[0].where.text()
                     + ": a tie and a uniform_axial condition in one scene are not "
                       "supported; use one of them");
  const double size = model.element_size();
  std::vector<TieConstraint::Pair> pairs;
  for (const TieSpec& t : scene.ties)
    pairs.push_back({t.where.text(), model.facets(t.slave, t.where),
                     model.facets(t.master, t.where),
                     t.tolerance > 0 ? t.tolerance : 0.25 * size});
  model.tie = std::make_shared<TieConstraint>(*model.problem().V(), pairs, model.fixed_dofs());
  model.constraint = model.tie;
}

void add_contacts(const Scene& scene, SceneModel& model, bool quiet)
{
  if (scene.contacts.empty())
    return;
  const double size = model.element_size();
  // the default penalty: 10 x the stiffest part's tangent at rest per element size
  double stiffness = 0;
  for (const Part& part : scene.parts)
  {
    MaterialPointModel m(part.parameters);
    m.set_time_factor(0);
    stiffness = std::max(stiffness, m.tangent(MaterialPoint{})[0]);
  }
  const std::vector<std::int32_t> fixed = model.fixed_dofs();
  for (std::size_t i = 0; i < scene.contacts.size(); ++i)
  {
    const ContactSpec& c = scene.contacts[i];
    const double eps = c.penalty > 0 ? c.penalty : 10 * stiffness / size;
    model.contacts.push_back(std::make_shared<ContactPair>(
        model.problem().u(),
        ContactPair::Settings{c.where.text(), model.facets(c.slave, c.where),
                              model.facets(c.master, c.where), eps, size, c.smooth_normals},
        fixed));
    model.built_contacts.push_back({{"pair", c.slave + " on " + c.master},
                                    {"penalty", eps},
                                    {"penalty_default", !(c.penalty > 0)},
                                    {"normals", c.smooth_normals ? "smooth" : "facet"}});
    if (!quiet and is_root())
      std::printf("contact[%zu] %s on %s: penalty %.6g kPa/mm%s\n", i, c.slave.c_str(),
                  c.master.c_str(), eps,
                  c.penalty > 0 ? "" : " (10 x the stiffest tangent / element size)");
  }
}

namespace
{
/// Every part's density on its local cells (owned and ghost).
std::vector<double> cell_densities(const Scene& scene, const SceneModel& model)
{
  auto cell_map = model.gm.mesh->topology().index_map(3);
  std::vector<double> density(cell_map->size_local() + cell_map->num_ghosts(), 0.0);
  for (std::size_t p = 0; p < model.body.size(); ++p)
    for (std::int32_t c : model.body[p]->cells())
      density[c] = scene.parts[p].density;
  return density;
}

/// The shortest time over which an input of the scene changes (a ramp's
/// duration, a table's shortest interval; 0 if none), and what it is.
std::pair<double, std::string> shortest_input_time(const Scene& scene)
{
  std::pair<double, std::string> shortest{0, ""};
  auto consider = [&](const TimeFunction& f, const std::string& what)
  {
    double tau = 0;
    if (f.kind == TimeFunction::Kind::ramp)
      tau = f.duration;
    else if (f.kind == TimeFunction::Kind::table)
      for (std::size_t i = 1; i < f.table.size(); ++i)
      {
        const double dt = f.table[i][0] - f.table[i - 1][0];
        tau = tau > 0 ? std::min(tau, dt) : dt;
      }
    if (tau > 0 and (shortest.first == 0 or tau < shortest.first))
      shortest = {tau, what};
  };
  for (const LoadSpec& l : scene.loads)
    consider(l.value, l.where.key);
  for (const BoundaryCondition& bc : scene.boundary)
    if (bc.kind == BoundaryCondition::Kind::displacement)
      consider(bc.value, bc.where.key);
  for (const Part& part : scene.parts)
    if (part.active)
      consider(part.activation_time, part.where.key + ".activation.time");
  return shortest;
}
} // namespace

void add_dynamics(const Scene& scene, SceneModel& model, bool quiet)
{
  if (!scene.dynamics)
    return;
  model.dynamics = std::make_shared<GeneralizedAlpha>(
      model.problem().u(), cell_densities(scene, model), model.bcs, scene.dynamics->rho_inf);
  model.dynamics->set_velocity(scene.dynamics->initial_velocity);
  // a second-order method follows an input's change with a few percent error
  // from about 10 steps over it on
  const auto [tau, what] = shortest_input_time(scene);
  if (tau > 0 and scene.time.dt > tau / 10)
  {
    char text[400];
    std::snprintf(text, sizeof text,
                  "time.step %.3g s resolves %s (changing over %.3g s) with fewer than 10 "
                  "steps: generalized-alpha misses its dynamics; use time.step <= %.3g s",
                  scene.time.dt, what.c_str(), tau, tau / 10);
    model.warnings.push_back(scene.dynamics->where.text() + ": " + text);
    if (!quiet and is_root())
      std::fprintf(stderr, "warning: %s\n", model.warnings.back().c_str());
  }
}

void add_loads(const Scene& scene, SceneModel& model)
{
  if (scene.loads.empty())
    return;
  const auto& mesh = *model.gm.mesh;
  model.loads = std::make_unique<Loads>(model.problem().u());
  const auto exterior = mesh::exterior_facet_indices(mesh.topology());
  const std::int32_t owned_facets = mesh.topology().index_map(2)->size_local();
  for (const LoadSpec& l : scene.loads)
  {
    auto value = [&l](double t) { return l.value(t); };
    if (l.kind == LoadSpec::Kind::gravity)
    {
      model.loads->add_gravity(l.vector, value, cell_densities(scene, model));
      continue;
    }
    const auto facets = model.facets(l.surface, l.where);
    std::int64_t inner = std::count_if(
        facets.begin(), facets.end(), [&](std::int32_t f)
        { return f < owned_facets and !std::binary_search(exterior.begin(), exterior.end(), f); });
    MPI_Allreduce(MPI_IN_PLACE, &inner, 1, MPI_INT64_T, MPI_SUM, mesh.comm());
    if (inner > 0)
      throw InputError(l.where.text() + ": '" + l.surface + "' has " + std::to_string(inner)
                       + " facets inside the body; a load acts on the boundary");
    if (l.kind == LoadSpec::Kind::pressure)
      model.loads->add_pressure(l.surface, facets, value);
    else
      model.loads->add_traction(l.surface, facets, l.vector, value);
  }
}

void set_time(const Scene& scene, SceneModel& model, double t)
{
  for (std::size_t p = 0; p < model.body.size(); ++p)
  {
    const Part& part = scene.parts[p];
    if (!part.active)
      continue;
    const double model_factor = model.model_time[p] ? time_factor(part.parameters, t) : 0.0;
    const double a = part.activation_time(t, model_factor);
    if (!(std::isfinite(a) and a >= 0))
      throw InputError(part.where.text() + ": activation.time is " + std::to_string(a)
                       + " at t = " + std::to_string(t) + "; it must be finite and >= 0");
    model.body[p]->set_time_factor(a);
    model.scales[p]->update(t); // checks itself on every rank
  }
  for (auto& [constant, bc] : model.moving)
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
  if (model.loads)
    model.loads->set_time(t);
}

void name_activation_scales(const Scene& scene, const SceneModel& model, StepFailure& failure)
{
  if (failure.reason.find("non-finite") == std::string::npos)
    return;
  for (std::size_t p = 0; p < model.scales.size(); ++p)
    if (model.scales[p])
    {
      char largest[32];
      std::snprintf(largest, sizeof largest, "%.6g", model.scales[p]->largest());
      failure.where += "; activation scale of part '" + scene.parts[p].name + "' up to "
                       + largest + " (" + scene.parts[p].activation_scale.where.text() + ")";
    }
}

NewtonOptions newton_options(const Scene& scene, const SceneModel& model)
{
  // Contact makes the energy along a Newton direction kinked where points enter
  // or leave contact, and the critical-point line search struggles there.
  // Measured on the Hertz scene, bt needs the fewest Newton iterations; on sliding
  // blocks basic diverges, cp and bt converge.  So bt with contact unless the scene
  // chooses (BENCHMARKS.md, "Line searches").
  NewtonOptions newton = scene.newton;
  if (!model.contacts.empty() and !scene.line_search_given)
    newton.line_search = "bt";
  return newton;
}

nlohmann::json describe_built(const Scene& scene, const SceneModel& model, bool quiet)
{
  const std::int64_t unknowns = model.unknowns();
  // what each part built; the first part's at the top level
  nlohmann::json built_parts = nlohmann::json::array();
  std::string forms_text;
  for (std::size_t p = 0; p < model.body.size(); ++p)
  {
    const Part& part = scene.parts[p];
    const MuscleProblem& problem = *model.body[p];
    built_parts.push_back(
        {{"part", part.name},
         {"forms", problem.kernel_name()},
         {"activation_terms", part.active},
         {"activation_kernel", problem.has_activation_kernel()},
         {"twitch_train", model.model_time[p] and uses_twitch_train(part.parameters.model())}});
    forms_text += (p ? ", " : "") + problem.kernel_name()
                  + (problem.has_activation_kernel() ? " + activation kernel" : "");
  }
  nlohmann::json built = built_parts[0];
  built.erase("part");
  built["axial_constraint_unknown"] = model.constraint != nullptr and !model.tie;
  built["loads"] = model.loads ? model.loads->describe() : std::vector<std::string>{};
  built["fixed_points"] = model.fixed_points;
  built["contact"] = model.built_contacts;
  built["line_search"] = newton_options(scene, model).line_search;
  built["tie_slave_nodes"] = model.tie ? model.tie->slave_nodes() : 0;
  if (model.tie)
    built["tie_largest_gap"] = model.tie->largest_gap();
  built["mass_matrix"] = false;
  built["element"] = {{"cell", model.cell_type},
                      {"degree", scene.mesh.degree},
                      {"fbar", model.element.fbar},
                      {"taylor_hood", model.element.taylor_hood}};
  built["unknowns"] = unknowns;
  // separately meshed bodies: GAMG's near-null space has six modes per body
  built["bodies"] = mesh_bodies(*model.problem().V()).count;
  if (model.body.size() > 1)
    built["parts"] = built_parts;
  if (!quiet and is_root())
    std::printf("%s: %s, %lld cells, %lld unknowns, %s%s degree %d, forms %s\n",
                scene.file.c_str(), scene.title.c_str(),
                static_cast<long long>(model.gm.num_cells), static_cast<long long>(unknowns),
                model.element.fbar ? "F-bar " : model.element.taylor_hood ? "Taylor-Hood " : "",
                model.cell_type.c_str(), scene.mesh.degree,
                forms_text.c_str());
  return built;
}

} // namespace muscle
