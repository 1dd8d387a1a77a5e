#pragma once

#include "scene/scene.h"

#include <dolfinx/fem/Function.h>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{
struct GmshMesh;
class MuscleProblem;
class PointData;
struct SceneModel;

/// Cell-wise activation scale of a part: evaluated once, or every step if it
/// depends on t.
class ScaleField
{
public:
  /// `cells`: the local cells of the part the scale belongs to.
  ScaleField(const ActivationScale& spec, const GmshMesh& gm, dolfinx::fem::Function<double>& scale,
             const std::vector<std::int32_t>& cells);
  ~ScaleField();

  /// The largest value over every rank's cells (collective).
  double largest() const;

  bool time_dependent() const;

  /// The values at t; InputError on every rank if one is negative or not finite.
  void update(double t, bool first = false);

private:
  const ActivationScale& _spec;
  dolfinx::fem::Function<double>& _scale;
  std::vector<double> _midpoints, _fixed;
  std::vector<std::int32_t> _dofs;
  std::unique_ptr<PointData> _data;
  std::vector<std::size_t> _rows;
};

/// A part's fibre field: one direction, the Laplace fibres between two of the
/// model's surfaces, or the nearest direction of a point-data file per cell.
void set_fibres(const FibreSpec& spec, const SceneModel& model, MuscleProblem& problem);

} // namespace muscle
