#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// Values given at scattered points, read from a CSV file with a header:
///   x,y,z,NAME...            (columns of values, e.g. a1,a2,a3 or scale)
///   x,y,z,0,0.05,0.1         (numeric headers: one column per time)
/// Each cell takes the row of the point nearest to its midpoint -- element-wise
/// data written for exactly this mesh matches cell by cell, coarser data
/// becomes piecewise constant.
class PointData
{
public:
  /// `columns`: the number of value columns required (0: any).  InputError
  /// naming file, line and column for malformed rows.
  PointData(const std::string& path, std::size_t columns);
  ~PointData();

  std::size_t columns() const { return _names.size(); }
  const std::vector<std::string>& names() const { return _names; }
  /// Are the value columns times (all headers numbers)?
  bool timed() const { return !_times.empty(); }

  /// Row index of the point nearest to x; on ties the first of them.
  std::size_t nearest(const std::array<double, 3>& x) const;

  double value(std::size_t row, std::size_t column) const
  {
    return _values[row * _names.size() + column];
  }
  /// Line of the file a row was read from.
  int line(std::size_t row) const { return _lines[row]; }

  /// Timed data: linear in time between columns, constant outside.
  double value_at(std::size_t row, double t) const;

private:
  std::vector<std::string> _names;
  std::vector<double> _times;
  std::vector<double> _values;
  std::vector<int> _lines;
  struct Tree;
  std::unique_ptr<const Tree> _tree; ///< the points, in a k-d tree
};

} // namespace muscle
