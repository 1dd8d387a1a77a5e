#pragma once

#include "scene/part_fields.h"
#include "scene/scene.h"

#include "fem/constraints/constraint.h"
#include "fem/contact/contact.h"
#include "fem/time/generalized_alpha.h"
#include "fem/terms/loads.h"
#include "fem/elements/muscle_problem.h"
#include "fem/constraints/tie_constraint.h"
#include "io/gmsh_mesh.h"

#include <array>
#include <dolfinx/fem/Constant.h>
#include <dolfinx/fem/DirichletBC.h>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace muscle
{

/// What a scene builds on its mesh, and nothing else.  Filled phase by phase, in
/// this order: read_mesh, choose_element, add_parts, add_boundary, add_ties,
/// add_contacts, add_loads.  Every scene mistake found on the mesh is an
/// InputError located at the scene key.
struct SceneModel
{
  // read_mesh
  GmshMesh gm; ///< the mesh with its named surfaces and volumes

  // choose_element
  std::string cell_type;
  Discretisation element;
  std::vector<std::string> warnings; ///< for summary.json; printed when found

  // add_parts: one problem per part; the parts share the first one's displacement
  std::shared_ptr<dolfinx::mesh::MeshTags<std::int32_t>> part_tags; ///< null: one part
  std::vector<std::unique_ptr<MuscleProblem>> problems;
  std::vector<MuscleProblem*> body;                ///< the problems, for the solver
  std::vector<std::unique_ptr<ScaleField>> scales; ///< null for a passive part
  std::vector<bool> model_time; ///< the part's activation is the material's own time function

  // add_boundary, add_ties
  std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> bcs;
  /// prescribed components whose value moves with t
  std::vector<std::pair<std::shared_ptr<dolfinx::fem::Constant<double>>, const BoundaryCondition*>>
      moving;
  std::shared_ptr<DisplacementConstraint> constraint; ///< uniform-axial or the tie
  std::shared_ptr<TieConstraint> tie;
  std::set<std::string> supports; ///< surfaces with Dirichlet values (reactions)
  std::vector<std::array<double, 3>> fixed_points; ///< nodes of fix_point

  // add_contacts
  std::vector<std::shared_ptr<ContactPair>> contacts;
  nlohmann::json built_contacts = nlohmann::json::array();

  // add_loads
  std::unique_ptr<Loads> loads; ///< null without loads
  // add_dynamics
  std::shared_ptr<GeneralizedAlpha> dynamics; ///< null: quasi-static

  /// The first part: it holds the displacement.
  MuscleProblem& problem() const { return *problems[0]; }
  /// The body's current volume (collective).
  double volume() const;
  /// Mean element size: the cube root of volume per cell (collective).
  double element_size() const;
  /// Local facets of a named surface; InputError located at `where` if the mesh has none.
  std::vector<std::int32_t> facets(const std::string& surface, const SceneLocation& where) const;
  /// Tag of a named surface; InputError located at `where` otherwise.
  int surface(const std::string& name, const SceneLocation& where) const;
  /// Local dofs with a Dirichlet condition, sorted.
  std::vector<std::int32_t> fixed_dofs() const;
  /// Newton's unknowns (the reduced count under a constraint).
  std::int64_t unknowns() const;
  /// The fields a checkpoint keeps: u, and the dynamic state.
  std::vector<std::shared_ptr<dolfinx::fem::Function<double>>> state() const;
};

/// The local cells of a mesh, owned and ghost.
std::vector<std::int32_t> all_cells(const dolfinx::mesh::Mesh& mesh);

/// The mesh (Gmsh, with the scene's mesh.set numbers).
SceneModel read_mesh(const Scene& scene);

/// F-bar on degree-1 hexahedra unless the scene says otherwise; plain linear
/// elements under a nearly incompressible law get a warning.
void choose_element(const Scene& scene, SceneModel& model);

/// One MuscleProblem per part with its material, fibres and activation scale.
void add_parts(const Scene& scene, SceneModel& model);

/// Clamps, prescribed components, fixed points and the uniform-axial constraint.
void add_boundary(const Scene& scene, SceneModel& model);

/// Ties of separately meshed bodies: one constraint for all pairs.
void add_ties(const Scene& scene, SceneModel& model);

/// Contact pairs with their penalties (printed unless `quiet`).
void add_contacts(const Scene& scene, SceneModel& model, bool quiet);

/// External loads, forms of their own.
void add_loads(const Scene& scene, SceneModel& model);
/// The generalized-alpha integrator of a dynamic scene (none without
/// `dynamics`); a warning if the time step cannot resolve a load's time scale.
void add_dynamics(const Scene& scene, SceneModel& model, bool quiet);

/// Activation, boundary values and loads at t, each checked: a user formula must
/// never feed a negative activation or a NaN displacement to the solver.
void set_time(const Scene& scene, SceneModel& model, double t);

/// A failure with a non-finite residual: an overflowing input, not the step, is
/// the usual cause, so `failure.where` names each part's largest activation
/// scale (collective).
void name_activation_scales(const Scene& scene, const SceneModel& model, StepFailure& failure);

/// The scene's Newton settings with the model's defaults filled in.
NewtonOptions newton_options(const Scene& scene, const SceneModel& model);

/// What was built, for summary.json ("built"); the one-line description is
/// printed unless `quiet`.
nlohmann::json describe_built(const Scene& scene, const SceneModel& model, bool quiet);

} // namespace muscle
