#pragma once

#include <array>
#include <dolfinx/fem/Function.h>
#include <memory>

namespace muscle
{

/// The displacement at the material point nearest given reference coordinates:
/// the point itself when it lies in the body, else the nearest point of the
/// body's surface.  One rank (the lowest that owns the cell) evaluates, all
/// ranks get the value, so every call is collective.
class PointProbe
{
public:
  PointProbe(std::shared_ptr<const dolfinx::fem::Function<double>> u,
             const std::array<double, 3>& x);

  /// u at the probe's point (collective).
  std::array<double, 3> displacement() const;

  /// The material point probed (reference configuration).
  const std::array<double, 3>& point() const { return _point; }

  /// Distance from the given coordinates to the probed point: 0 inside the body.
  double distance() const { return _distance; }

private:
  std::shared_ptr<const dolfinx::fem::Function<double>> _u;
  std::array<double, 3> _point;
  double _distance = 0;
  int _owner = 0;         ///< the rank that evaluates
  std::int32_t _cell = -1; ///< on the owner
};

} // namespace muscle
