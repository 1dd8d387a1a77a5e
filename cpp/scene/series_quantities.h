#pragma once

#include "scene/scene.h"

#include <dolfinx/fem/Form.h>
#include <dolfinx/la/Vector.h>
#include <dolfinx/mesh/MeshTags.h>
#include <functional>
#include <memory>
#include <vector>

namespace muscle
{
struct SceneModel;
class NonlinearSolver;

/// The columns of series.csv (scene output.series): one measuring function per
/// column, built once on the model.  InputError for a column the model cannot
/// measure (a reaction on a surface without support, a section that is no
/// plane, an unknown part or contact pair, a point outside the body).
class SeriesQuantities
{
public:
  SeriesQuantities(const Scene& scene, const SceneModel& model);
  SeriesQuantities(const SeriesQuantities&) = delete;
  SeriesQuantities& operator=(const SeriesQuantities&) = delete;

  /// Every column at the current state (collective); `solver` assembles the
  /// nodal forces that reactions sum.
  std::vector<double> measure(const NonlinearSolver& solver);

private:
  using Measure = std::function<double()>;
  Measure reaction(const SeriesQuantity& q, const std::vector<std::int32_t>& dofs);
  Measure section_force(const SeriesQuantity& q, const std::vector<std::int32_t>& dofs);
  Measure rotation(const SeriesQuantity& q) const;
  Measure contact(const SeriesQuantity& q) const;
  Measure point(const SeriesQuantity& q) const;

  const Scene& _scene;
  const SceneModel& _model;
  dolfinx::la::Vector<double> _nodal; ///< nodal forces (reactions)
  bool _need_nodal_forces = false;
  std::vector<Measure> _measure;
  std::vector<std::shared_ptr<dolfinx::mesh::MeshTags<std::int32_t>>> _keep_tags;
};

} // namespace muscle
