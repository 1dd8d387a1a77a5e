#include "scene/point_data.h"

#include "common/errors.h"

#include <nanoflann.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace muscle
{

/// The points as nanoflann reads them, and the tree over them.
struct PointData::Tree
{
  explicit Tree(std::vector<std::array<double, 3>> p) : points(std::move(p)) {}
  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t row, std::size_t d) const { return points[row][d]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const
  {
    return false;
  }

  const std::vector<std::array<double, 3>> points;
  const nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Tree>, Tree, 3>
      index{3, *this};
};

namespace
{
/// nanoflann result set: the nearest point, of equally near ones the lowest row
/// (a rule of the data, not of the tree's layout).  nanoflann only looks at
/// points closer than worstDist(); a little more than the best distance so far
/// lets the ties through, and the points that rounding in the tree's bounds
/// could hide.
struct Nearest
{
  double best = std::numeric_limits<double>::infinity();
  std::size_t row = 0;

  double worstDist() const
  {
    return std::nextafter(best * (1 + 1e-12), std::numeric_limits<double>::infinity());
  }
  bool addPoint(double d2, std::size_t r)
  {
    if (d2 < best or (d2 == best and r < row))
      best = d2, row = r;
    return true;
  }
  bool full() const { return true; } // findNeighbors returns it
};

std::vector<std::string> split(const std::string& line)
{
  std::vector<std::string> fields;
  std::stringstream s(line);
  for (std::string f; std::getline(s, f, ',');)
  {
    f.erase(0, f.find_first_not_of(" \t\r"));
    f.erase(f.find_last_not_of(" \t\r") + 1);
    fields.push_back(f);
  }
  return fields;
}

} // namespace

PointData::PointData(const std::string& path, std::size_t columns)
{
  std::ifstream in(path);
  if (!in)
    throw InputError(path + ": cannot be read");
  std::vector<std::array<double, 3>> points;
  std::string line;
  int number = 0;
  auto where = [&] { return path + ":" + std::to_string(number) + ": "; };
  while (std::getline(in, line))
  {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos or line[0] == '#')
      continue;
    const std::vector<std::string> fields = split(line);
    if (_names.empty() and points.empty())
    {
      if (fields.size() < 4 or fields[0] != "x" or fields[1] != "y" or fields[2] != "z")
        throw InputError(where() + "the header must be x,y,z followed by value columns, found '"
                         + line + "'");
      _names.assign(fields.begin() + 3, fields.end());
      if (columns > 0 and _names.size() != columns)
        throw InputError(where() + "expected " + std::to_string(columns)
                         + " value column(s) after x,y,z, found " + std::to_string(_names.size()));
      std::vector<double> times;
      for (const std::string& n : _names)
      {
        if (const auto time = parse_real(n))
        {
          const double t = *time;
          if (!times.empty() and !(t > times.back()))
            throw InputError(where() + "time columns must increase ('" + n + "')");
          times.push_back(t);
        }
      }
      if (times.size() == _names.size() and times.size() > 1)
        _times = times;
      continue;
    }
    if (fields.size() != _names.size() + 3)
      throw InputError(where() + "expected " + std::to_string(_names.size() + 3)
                       + " values, found " + std::to_string(fields.size()));
    std::array<double, 3> x;
    for (std::size_t k = 0; k < fields.size(); ++k)
    {
      const auto value = parse_real(fields[k]);
      if (!value)
        throw InputError(where() + "column " + std::to_string(k + 1) + " ('"
                         + (k < 3 ? std::string(1, "xyz"[k]) : _names[k - 3]) + "'): '"
                         + fields[k] + "' is not a finite number");
      if (k < 3)
        x[k] = *value;
      else
        _values.push_back(*value);
    }
    points.push_back(x);
    _lines.push_back(number);
  }
  if (points.empty())
    throw InputError(path + ": no data rows");

  _tree = std::make_unique<const Tree>(std::move(points));
}

PointData::~PointData() = default;

std::size_t PointData::nearest(const std::array<double, 3>& x) const
{
  Nearest result;
  _tree->index.findNeighbors(result, x.data(), nanoflann::SearchParams());
  return result.row;
}

double PointData::value_at(std::size_t row, double t) const
{
  if (_times.empty())
    return value(row, 0);
  if (t <= _times.front())
    return value(row, 0);
  for (std::size_t k = 1; k < _times.size(); ++k)
    if (t <= _times[k])
    {
      const double s = (t - _times[k - 1]) / (_times[k] - _times[k - 1]);
      return (1 - s) * value(row, k - 1) + s * value(row, k);
    }
  return value(row, _times.size() - 1);
}

} // namespace muscle
