#include "point_data.h"

#include "../common/errors.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace muscle
{
namespace
{
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
  std::string line;
  int number = 0;
  auto where = [&] { return path + ":" + std::to_string(number) + ": "; };
  while (std::getline(in, line))
  {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos or line[0] == '#')
      continue;
    const std::vector<std::string> fields = split(line);
    if (_names.empty() and _points.empty())
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
    _points.push_back(x);
    _lines.push_back(number);
  }
  if (_points.empty())
    throw InputError(path + ": no data rows");

  // about two points per bucket
  std::array<double, 3> upper;
  for (int d = 0; d < 3; ++d)
  {
    _lower[d] = std::numeric_limits<double>::infinity();
    upper[d] = -_lower[d];
    for (const auto& p : _points)
    {
      _lower[d] = std::min(_lower[d], p[d]);
      upper[d] = std::max(upper[d], p[d]);
    }
  }
  const double per_axis = std::max(1.0, std::cbrt(_points.size() / 2.0));
  for (int d = 0; d < 3; ++d)
  {
    const double extent = upper[d] - _lower[d];
    _count[d] = extent > 0 ? static_cast<int>(std::ceil(per_axis)) : 1;
    _width[d] = extent > 0 ? extent / _count[d] : 1;
  }
  _buckets.resize(static_cast<std::size_t>(_count[0]) * _count[1] * _count[2]);
  for (std::size_t i = 0; i < _points.size(); ++i)
  {
    const auto b = bucket_of(_points[i]);
    _buckets[(static_cast<std::size_t>(b[0]) * _count[1] + b[1]) * _count[2] + b[2]].push_back(i);
  }
}

std::array<int, 3> PointData::bucket_of(const std::array<double, 3>& x) const
{
  std::array<int, 3> b;
  for (int d = 0; d < 3; ++d)
    b[d] = std::clamp(static_cast<int>(std::floor((x[d] - _lower[d]) / _width[d])), 0,
                      _count[d] - 1);
  return b;
}

std::size_t PointData::nearest(const std::array<double, 3>& x) const
{
  const auto home = bucket_of(x);
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_row = 0;
  const int rings = std::max({_count[0], _count[1], _count[2]});
  for (int r = 0; r <= rings; ++r)
  {
    // points in ring r are at least (r - 1) bucket widths away
    double reach = std::numeric_limits<double>::infinity();
    for (int d = 0; d < 3; ++d)
      if (_count[d] > 1)
        reach = std::min(reach, (r - 1) * _width[d]);
    if (r > 1 and reach * reach > best)
      break;
    for (int i = home[0] - r; i <= home[0] + r; ++i)
      for (int j = home[1] - r; j <= home[1] + r; ++j)
        for (int k = home[2] - r; k <= home[2] + r; ++k)
        {
          if (std::max({std::abs(i - home[0]), std::abs(j - home[1]), std::abs(k - home[2])}) != r)
            continue;
          if (i < 0 or j < 0 or k < 0 or i >= _count[0] or j >= _count[1] or k >= _count[2])
            continue;
          for (std::size_t row :
               _buckets[(static_cast<std::size_t>(i) * _count[1] + j) * _count[2] + k])
          {
            const auto& p = _points[row];
            const double d2 = (p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1])
                              + (p[2] - x[2]) * (p[2] - x[2]);
            if (d2 < best)
            {
              best = d2;
              best_row = row;
            }
          }
        }
  }
  return best_row;
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
